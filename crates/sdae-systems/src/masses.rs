//! Particle masses as they appear in parameter files.

use sdae_manifold::DiagonalMass;
use serde::{Deserialize, Serialize};

use crate::error::SystemError;

/// The masses of the particles (atoms, beads) of a system (unit: mass): one number for all of them
/// or a list with one entry per particle. In a parameter file this is a number (`masses = 1.0`)
/// or an array (`masses = [16.0, 1.0, 1.0]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Masses {
    /// Every particle has this mass.
    Uniform(f64),
    /// Particle i has mass `masses[i]`.
    PerParticle(Vec<f64>),
}

impl Default for Masses {
    /// Unit masses.
    fn default() -> Self {
        Self::Uniform(1.0)
    }
}

impl Masses {
    /// The mass of each of `particles` particles; each must be finite and > 0, and a list must
    /// have one entry per particle.
    pub fn resolve(&self, particles: usize) -> Result<Vec<f64>, SystemError> {
        let masses = match self {
            Self::Uniform(m) => vec![*m; particles],
            Self::PerParticle(list) if list.len() == particles => list.clone(),
            Self::PerParticle(list) => {
                return Err(SystemError::WrongLength {
                    name: "masses",
                    expected: particles,
                    found: list.len(),
                });
            }
        };
        match masses.iter().position(|m| !(m.is_finite() && *m > 0.0)) {
            None => Ok(masses),
            Some(index) => Err(SystemError::InvalidEntry {
                name: "masses",
                index,
                value: masses[index],
                rule: "every mass must be finite and > 0",
            }),
        }
    }

    /// The diagonal mass matrix of `particles` particles in R^3 (each mass repeated 3 times).
    pub fn matrix(&self, particles: usize) -> Result<DiagonalMass, SystemError> {
        Ok(DiagonalMass::per_particle(&self.resolve(particles)?, 3)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masses_resolve_or_name_the_problem() {
        assert_eq!(Masses::Uniform(2.0).resolve(3).unwrap(), vec![2.0; 3]);
        assert_eq!(
            Masses::PerParticle(vec![1.0, 2.0]).resolve(3).unwrap_err(),
            SystemError::WrongLength {
                name: "masses",
                expected: 3,
                found: 2
            }
        );
        let e = Masses::PerParticle(vec![1.0, 0.0]).resolve(2).unwrap_err();
        assert!(
            matches!(
                e,
                SystemError::InvalidEntry {
                    name: "masses",
                    index: 1,
                    ..
                }
            ),
            "{e}"
        );
        let e = Masses::Uniform(f64::NAN).resolve(2).unwrap_err();
        assert!(
            matches!(
                e,
                SystemError::InvalidEntry {
                    name: "masses",
                    index: 0,
                    ..
                }
            ),
            "{e}"
        );
    }
}
