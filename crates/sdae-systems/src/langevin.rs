//! Constrained Langevin dynamics of molecular dynamics (seed Section 5.2).
//!
//! With q = r, p = M v and the multiplier mu = lambda of the seed's citation, the equations
//! of seed Section 5.2 are the SDAE of eq. 1.1 with
//!
//! ```text
//! M dv = [-grad V(r) - gamma v] dt + sigma dw + grad g(r) dmu,   g(r) = 0,
//! sigma^2 = 2 gamma kT   (fluctuation-dissipation: B B^T = 2 kT x friction matrix gamma I),
//! ```
//!
//! M diagonal with one mass per atom, w of dimension l = n = 3N. At equilibrium the velocity
//! given the position is Gaussian on the tangent space with covariance kT M^-1 restricted to
//! it, so E[v^T M v / 2] = (n - m) kT / 2 (equipartition over the n - m free directions); the
//! velocities relax on the times m_a / gamma.
//!
//! - [`Langevin`]: any constraint with any [`Potential`];
//! - [`chain_molecule`]: N atoms in a chain with equal rigid bonds ([`BeadChain`]), optional
//!   [`BondAngles`] and [`Torsions`] ([`ChainMoleculeParams`]);
//! - [`rigid_triatomic`]: a rigid triangle of 3 atoms ([`RigidBonds`]) in a [`HarmonicTrap`]
//!   ([`RigidTriatomicParams`]).
//!
//! The initial state lies on the tangent bundle (g(r) = 0, Dg(r) v = 0); `sdae_scheme::Stepper`
//! steps it (its documentation has this molecule's path):
//!
//! ```
//! use sdae_manifold::Constraint;
//! use sdae_model::System;
//! use sdae_systems::{ChainMoleculeParams, chain_molecule};
//! let molecule = chain_molecule(&ChainMoleculeParams::default())?;
//! let (r, v) = molecule.initial_state();
//! let m = molecule.constraint().n_constraints();
//! let (mut g, mut dg_v) = (vec![1.0; m], vec![1.0; m]);
//! molecule.constraint().value(&r, &mut g);
//! molecule.constraint().jacobian_mul(&r, &v, &mut dg_v);
//! assert!(g.iter().chain(&dg_v).all(|x| x.abs() < 1e-12));
//! let mut a = vec![0.0; r.len()];
//! molecule.drift(&r, &v, &mut a);
//! assert!(a.iter().all(|x| x.is_finite()));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use sdae_lanes::Real;
use sdae_manifold::{BeadChain, Constraint, DiagonalMass, Mass, RigidBonds};
use sdae_model::{AdditiveNoise, LangevinForm, Noise, System};
use serde::{Deserialize, Serialize};

use crate::error::{SystemError, non_negative, particle_count, positive};
use crate::masses::Masses;
use crate::potential::{
    AngleParams, BondAngles, HarmonicTrap, Potential, TorsionParams, Torsions, TrapParams,
};

/// A constrained Langevin system: constraint g, diagonal mass M, potential V, friction gamma
/// and temperature kT; drift a(r, v) = -grad V(r) - gamma v, noise B = sqrt(2 gamma kT) I.
/// Without noise (gamma = 0 or kT = 0) it draws no random numbers (l = 0).
#[derive(Debug, Clone)]
pub struct Langevin<C, P> {
    constraint: C,
    mass: DiagonalMass,
    potential: P,
    friction: f64,
    temperature: f64,
    /// sigma I_n with sigma = sqrt(2 gamma kT).
    noise: AdditiveNoise,
}

impl<C: Constraint, P: Potential> Langevin<C, P> {
    /// Checks friction gamma >= 0 (unit: mass / time) and temperature kT >= 0 (unit: energy),
    /// both finite, with a finite noise amplitude sqrt(2 gamma kT), that the mass has order n
    /// and that the potential acts only on atoms of the system.
    pub fn new(
        constraint: C, mass: DiagonalMass, potential: P, friction: f64, temperature: f64,
    ) -> Result<Self, SystemError> {
        non_negative("friction", friction)?;
        non_negative("temperature", temperature)?;
        let n = constraint.dim();
        mass.check_order(n)?;
        if potential.min_dim() > n {
            return Err(SystemError::InvalidParameter {
                name: "potential",
                value: (potential.min_dim() / 3 - 1) as f64,
                rule: "a potential term names an atom index >= the number of atoms",
            });
        }
        Ok(Self {
            constraint,
            mass,
            potential,
            friction,
            temperature,
            noise: AdditiveNoise::new((2.0 * friction * temperature).sqrt(), n)?,
        })
    }

    /// The potential V.
    pub fn potential(&self) -> &P {
        &self.potential
    }

    /// The friction gamma.
    pub fn friction(&self) -> f64 {
        self.friction
    }

    /// The temperature kT.
    pub fn temperature(&self) -> f64 {
        self.temperature
    }

    /// The noise amplitude sigma = sqrt(2 gamma kT).
    pub fn noise_amplitude(&self) -> f64 {
        self.noise.sigma()
    }

    /// The dimension l of the Brownian motion: n, or 0 without noise.
    pub fn noise_dimension(&self) -> usize {
        self.noise.dim()
    }

    /// The number n - m of free directions.
    pub fn degrees_of_freedom(&self) -> usize {
        self.constraint.dim() - self.constraint.n_constraints()
    }

    /// The equilibrium mean of the kinetic energy, (n - m) kT / 2.
    pub fn equipartition_energy(&self) -> f64 {
        0.5 * self.degrees_of_freedom() as f64 * self.temperature
    }

    /// The kinetic energy v^T M v / 2.
    pub fn kinetic_energy(&self, v: &[f64]) -> f64 {
        self.mass.kinetic_energy(v)
    }

    /// The total energy v^T M v / 2 + V(r).
    pub fn energy(&self, r: &[f64], v: &[f64]) -> f64 {
        self.kinetic_energy(v) + self.potential.energy(r)
    }
}

impl<C: Constraint, P: Potential> System for Langevin<C, P> {
    type Constraint = C;
    type Mass = DiagonalMass;
    fn constraint(&self) -> &C {
        &self.constraint
    }
    fn mass(&self) -> &DiagonalMass {
        &self.mass
    }
    /// a(r, v) = -grad V(r) - gamma v: the friction, then the potential's force
    /// ([`Potential::add_force`]; `false` where the lanes have no evaluation of it).
    #[inline(always)]
    fn drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) -> bool {
        for (o, &vi) in out.iter_mut().zip(v) {
            *o = vi * -self.friction;
        }
        self.potential.add_force(r, out)
    }
    fn noise_dim(&self) -> usize {
        self.noise_dimension()
    }
    /// out += sigma dw.
    #[inline(always)]
    fn add_noise<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) -> bool {
        self.noise.add(r, v, dw, out)
    }
    /// a(r, v) = -grad V(r) - gamma v, B = sqrt(2 gamma kT) I.
    fn langevin(&self) -> Option<LangevinForm> {
        Some(LangevinForm {
            friction: self.friction,
            noise: self.noise.sigma(),
        })
    }
}

/// The potential of a chain molecule: bond angles and torsions, each absent (`None`, no cost)
/// when its stiffness is 0.
pub type ChainPotential = (Option<BondAngles>, Option<Torsions>);

/// A linear chain molecule with equal rigid bonds.
pub type ChainMolecule = Langevin<BeadChain, ChainPotential>;

/// Parameters of [`chain_molecule`] in any consistent units (the defaults are reduced units:
/// bond length, atom mass and kT equal to 1). In a file every field is required except the
/// optional `angle` and `torsion` tables (off); unknown fields are an error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChainMoleculeParams {
    /// Number of atoms N >= 2 (N - 1 rigid bonds between consecutive atoms).
    pub atoms: usize,
    /// The common bond length L > 0 (unit: length).
    pub bond_length: f64,
    /// Atom masses (unit: mass): one for all atoms or one per atom.
    pub masses: Masses,
    /// Friction gamma >= 0 (unit: mass / time); velocities relax on the times m_a / gamma.
    pub friction: f64,
    /// Temperature kT >= 0 (unit: energy).
    pub temperature: f64,
    /// Harmonic angle potential at each inner atom (off when the stiffness is 0; optional in a
    /// file: off).
    #[serde(default)]
    pub angle: AngleParams,
    /// Dihedral cosine potential about each inner bond (off when the stiffness is 0; optional
    /// in a file: off).
    #[serde(default)]
    pub torsion: TorsionParams,
}

impl Default for ChainMoleculeParams {
    /// An alkane-like chain of 8 unit atoms at kT = 1, gamma = 1: angle stiffness 20 kT/rad^2
    /// at 109.47 degrees, threefold torsion of height 2 kT.
    fn default() -> Self {
        Self {
            atoms: 8,
            bond_length: 1.0,
            masses: Masses::default(),
            friction: 1.0,
            temperature: 1.0,
            angle: AngleParams {
                stiffness: 20.0,
                ..AngleParams::default()
            },
            torsion: TorsionParams {
                stiffness: 1.0,
                ..TorsionParams::default()
            },
        }
    }
}

/// Builds the chain molecule; fails with the name, value and rule of the first bad parameter.
pub fn chain_molecule(params: &ChainMoleculeParams) -> Result<ChainMolecule, SystemError> {
    let atoms = particle_count(
        "atoms",
        params.atoms,
        2,
        "a chain molecule needs >= 2 atoms",
    )?;
    positive("bond_length", params.bond_length)?;
    let angles = BondAngles::chain(atoms, params.angle)?;
    let torsions = Torsions::chain(atoms, params.torsion)?;
    let potential = (
        (params.angle.stiffness > 0.0 && !angles.triples().is_empty()).then_some(angles),
        (params.torsion.stiffness > 0.0 && !torsions.quadruples().is_empty()).then_some(torsions),
    );
    Langevin::new(
        BeadChain::new(atoms, params.bond_length)?,
        params.masses.matrix(atoms)?,
        potential,
        params.friction,
        params.temperature,
    )
}

impl ChainMolecule {
    /// A planar all-trans zigzag in the x-y plane, atom 0 at the origin, at the equilibrium bond
    /// angle of the angle potential (the tetrahedral angle when that potential is off), and
    /// zero velocity: a state on the tangent bundle to start a path from.
    pub fn initial_state(&self) -> (Vec<f64>, Vec<f64>) {
        let theta = self
            .potential
            .0
            .as_ref()
            .map_or(AngleParams::default().equilibrium, |a| {
                a.params().equilibrium
            });
        let r = self.constraint.zigzag(0.5 * (std::f64::consts::PI - theta));
        let v = vec![0.0; r.len()];
        (r, v)
    }
}

/// A rigid triatomic molecule in a harmonic trap.
pub type RigidTriatomic = Langevin<RigidBonds, HarmonicTrap>;

/// Parameters of [`rigid_triatomic`] in any consistent units (the defaults are reduced units).
/// In a file every field is required; unknown fields are an error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidTriatomicParams {
    /// Bond lengths (unit: length) of the bonds 0-1, 0-2 and 1-2: each finite, > 0, and shorter
    /// than the sum of the other two (a non-degenerate triangle).
    #[serde(deserialize_with = "crate::exact::array")]
    pub bond_lengths: [f64; 3],
    /// Atom masses (unit: mass): one for all atoms or a list of 3.
    pub masses: Masses,
    /// Harmonic trap acting on every atom.
    pub trap: TrapParams,
    /// Friction gamma >= 0 (unit: mass / time).
    pub friction: f64,
    /// Temperature kT >= 0 (unit: energy).
    pub temperature: f64,
}

impl Default for RigidTriatomicParams {
    /// A water-like molecule in reduced units: two bonds of length 1 at 104.52 degrees
    /// (so the third side is 1.5816), masses 16, 1, 1, unit trap, gamma = 1, kT = 1.
    fn default() -> Self {
        let half_angle = 0.5 * 104.52_f64.to_radians();
        Self {
            bond_lengths: [1.0, 1.0, 2.0 * half_angle.sin()],
            masses: Masses::PerParticle(vec![16.0, 1.0, 1.0]),
            trap: TrapParams::default(),
            friction: 1.0,
            temperature: 1.0,
        }
    }
}

/// Builds the rigid triatomic; fails with the name, value and rule of the first bad parameter.
///
/// The triangle's bond network is braced, so [`RigidBonds`] bounds C_g and the theory's
/// constants are available:
///
/// ```
/// use sdae_manifold::Constraint;
/// use sdae_model::System;
/// use sdae_systems::{RigidTriatomicParams, rigid_triatomic};
/// let molecule = rigid_triatomic(&RigidTriatomicParams::default())?;
/// let target = molecule.equipartition_energy();
/// assert_eq!(target, 3.0); // (9 - 3) kT / 2
/// let (r, v) = molecule.initial_state();
/// let mut g = [1.0; 3];
/// molecule.constraint().value(&r, &mut g);
/// assert!(g.iter().all(|x| x.abs() < 1e-12));
/// assert_eq!(molecule.kinetic_energy(&v), 0.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn rigid_triatomic(params: &RigidTriatomicParams) -> Result<RigidTriatomic, SystemError> {
    let [l01, l02, l12] = params.bond_lengths;
    for (index, &l) in params.bond_lengths.iter().enumerate() {
        if !(l.is_finite() && l > 0.0) {
            return Err(SystemError::InvalidEntry {
                name: "bond_lengths",
                index,
                value: l,
                rule: "every bond length must be finite and > 0",
            });
        }
    }
    let total = l01 + l02 + l12;
    if let Some(index) = params.bond_lengths.iter().position(|&l| l >= total - l) {
        return Err(SystemError::InvalidEntry {
            name: "bond_lengths",
            index,
            value: params.bond_lengths[index],
            rule: "each bond must be shorter than the sum of the other two",
        });
    }
    Langevin::new(
        RigidBonds::new(3, &[(0, 1, l01), (0, 2, l02), (1, 2, l12)])?,
        params.masses.matrix(3)?,
        HarmonicTrap::new(params.trap)?,
        params.friction,
        params.temperature,
    )
}

impl RigidTriatomic {
    /// The triangle in the x-y plane with its center of mass at the trap center, atom 1 along
    /// +x from atom 0, and zero velocity: a state on the tangent bundle to start a path from.
    pub fn initial_state(&self) -> (Vec<f64>, Vec<f64>) {
        let length = |p, q| {
            self.constraint
                .bond_between(p, q)
                .map_or(0.0, |b| self.constraint.bonds()[b].length)
        };
        let (l01, l02, l12) = (length(0, 1), length(0, 2), length(1, 2));
        let cos = (l01 * l01 + l02 * l02 - l12 * l12) / (2.0 * l01 * l02);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let mut r = vec![0.0, 0.0, 0.0, l01, 0.0, 0.0, l02 * cos, l02 * sin, 0.0];
        let m = self.mass.diagonal();
        let total: f64 = (0..3).map(|a| m[3 * a]).sum();
        let center = self.potential.params().center;
        for k in 0..3 {
            let com = (0..3).map(|a| m[3 * a] * r[3 * a + k]).sum::<f64>() / total;
            for a in 0..3 {
                r[3 * a + k] += center[k] - com;
            }
        }
        (r, vec![0.0; 9])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sdae_manifold::check_state;

    #[test]
    fn initial_states_are_on_the_tangent_bundle() {
        let chain = chain_molecule(&ChainMoleculeParams::default()).unwrap();
        let (r, v) = chain.initial_state();
        check_state(chain.constraint(), &r, &v, 1e-14).unwrap();
        let angles = chain.potential().0.as_ref().unwrap();
        assert!(angles.energy(&r) < 1e-20, "zigzag at the equilibrium angle");
        let molecule = rigid_triatomic(&RigidTriatomicParams::default()).unwrap();
        let (r, v) = molecule.initial_state();
        check_state(molecule.constraint(), &r, &v, 1e-14).unwrap();
    }

    #[test]
    fn lane_forms_are_the_scalar_forces_bit_for_bit() {
        use crate::vec3::check::{lane_forms_match_scalar, states_near};
        let chain = chain_molecule(&ChainMoleculeParams::default()).unwrap();
        let (r0, _) = chain.initial_state();
        let mut states = states_near(&r0, 11);
        // Path 3: atoms 0, 1, 2 collinear and atom 3 beyond them (no bending plane: the angle
        // at atom 1 and the first torsion add no force).
        for a in 0..4 {
            states[3][0][3 * a..3 * a + 3].copy_from_slice(&[a as f64, 0.0, 0.0]);
        }
        lane_forms_match_scalar(&chain, &states);
        let molecule = rigid_triatomic(&RigidTriatomicParams::default()).unwrap();
        let (r0, _) = molecule.initial_state();
        lane_forms_match_scalar(&molecule, &states_near(&r0, 9));
    }

    #[test]
    fn zero_stiffness_terms_are_absent_and_zero_noise_draws_nothing() {
        let params = ChainMoleculeParams {
            angle: AngleParams::default(),
            torsion: TorsionParams::default(),
            temperature: 0.0,
            ..ChainMoleculeParams::default()
        };
        let chain = chain_molecule(&params).unwrap();
        assert!(chain.potential().0.is_none() && chain.potential().1.is_none());
        assert_eq!(chain.noise_dim(), 0);
        let two = chain_molecule(&ChainMoleculeParams {
            atoms: 2,
            ..ChainMoleculeParams::default()
        })
        .unwrap();
        assert!(two.potential().0.is_none() && two.potential().1.is_none());
        assert_eq!(two.noise_dim(), 6);
    }

    /// The error of building a chain molecule from `params`.
    fn chain_error(params: ChainMoleculeParams) -> SystemError {
        chain_molecule(&params).unwrap_err()
    }

    /// The error of building a rigid triatomic molecule from `params`.
    fn triatomic_error(params: RigidTriatomicParams) -> SystemError {
        rigid_triatomic(&params).unwrap_err()
    }

    #[test]
    fn bad_chain_parameters_are_named() {
        let e = chain_error(ChainMoleculeParams {
            atoms: 1,
            ..ChainMoleculeParams::default()
        });
        assert!(
            matches!(e, SystemError::InvalidParameter { name: "atoms", .. }),
            "{e}"
        );
        let e = chain_error(ChainMoleculeParams {
            temperature: -1.0,
            ..ChainMoleculeParams::default()
        });
        assert_eq!(
            e,
            SystemError::InvalidParameter {
                name: "temperature",
                value: -1.0,
                rule: "must be finite and >= 0"
            }
        );
        let e = chain_error(ChainMoleculeParams {
            friction: f64::INFINITY,
            ..ChainMoleculeParams::default()
        });
        assert_eq!(e.parameter(), Some("friction"), "{e}");
        let e = chain_error(ChainMoleculeParams {
            bond_length: 0.0,
            ..ChainMoleculeParams::default()
        });
        assert_eq!(e.parameter(), Some("bond_length"), "{e}");
    }

    #[test]
    fn an_overflowing_chain_noise_is_a_model_error() {
        let e = chain_error(ChainMoleculeParams {
            friction: 1e300,
            temperature: 1e300,
            ..ChainMoleculeParams::default()
        });
        assert!(matches!(e, SystemError::Model(_)), "sigma overflows: {e}");
    }

    #[test]
    fn chain_masses_of_the_wrong_length_are_named() {
        let e = chain_error(ChainMoleculeParams {
            masses: Masses::PerParticle(vec![1.0; 3]),
            ..ChainMoleculeParams::default()
        });
        assert!(
            matches!(
                e,
                SystemError::WrongLength {
                    name: "masses",
                    expected: 8,
                    found: 3
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn bad_triatomic_bond_lengths_are_named_with_their_entry() {
        // Lengths of a flat triangle (1 + 1 = 2), then one that is not a number.
        for (bond_lengths, entry) in [([1.0, 1.0, 2.0], 2), ([1.0, f64::NAN, 1.0], 1)] {
            let e = triatomic_error(RigidTriatomicParams {
                bond_lengths,
                ..RigidTriatomicParams::default()
            });
            assert!(
                matches!(
                    e,
                    SystemError::InvalidEntry {
                        name: "bond_lengths",
                        index,
                        ..
                    } if index == entry
                ),
                "{e}"
            );
        }
    }

    #[test]
    fn a_bad_triatomic_trap_is_named() {
        let e = triatomic_error(RigidTriatomicParams {
            trap: TrapParams {
                stiffness: f64::NAN,
                center: [0.0; 3],
            },
            ..RigidTriatomicParams::default()
        });
        assert_eq!(e.parameter(), Some("trap.stiffness"), "{e}");
    }

    #[test]
    fn potential_beyond_the_atoms_is_rejected() {
        let angles = BondAngles::new(vec![[0, 1, 5]], AngleParams::default()).unwrap();
        let e = Langevin::new(
            BeadChain::new(3, 1.0).unwrap(),
            Masses::default().matrix(3).unwrap(),
            angles,
            1.0,
            1.0,
        )
        .unwrap_err();
        assert!(
            matches!(
                e,
                SystemError::InvalidParameter {
                    name: "potential",
                    value: 5.0,
                    ..
                }
            ),
            "{e}"
        );
    }
}
