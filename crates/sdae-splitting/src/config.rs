//! The settings of a splitting scheme: the number of geodesic substeps K_r of the A step and
//! the SHAKE projection's solver.

use sdae_ift::SolverSettings;

use crate::error::SplittingError;

/// Settings of [`Splitting`](crate::Splitting).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplittingConfig {
    /// K_r >= 1: each A half-step of size h/2 is K_r geodesic substeps of h / (2 K_r), each a
    /// SHAKE position projection followed by the RATTLE velocity projection. 1 is BAOAB, 3
    /// is the g-BAOAB of Leimkuhler and Matthews (2016) as molecular-dynamics codes run it
    /// ("V R R R O R R R V").
    pub substeps: usize,
    /// The SHAKE projection's Newton on the multipliers: tolerance on max_i |g_i| (the
    /// built-in constraints' g is relative, (1 - |d|^2 / L^2) / 2 for a length L), iteration
    /// limit; no homotopy, as in molecular-dynamics codes (a projection that fails is a
    /// failed step).
    pub solver: SolverSettings,
    /// Measure max |Dg(r') v'| after each step (costs one Jacobian product).
    pub monitor_velocity_constraint: bool,
}

/// The default SHAKE tolerance on max |g|.
pub const DEFAULT_TOLERANCE: f64 = 1e-12;

/// The default number of geodesic substeps of g-BAOAB.
pub const G_BAOAB_SUBSTEPS: usize = 3;

impl SplittingConfig {
    /// Constrained BAOAB ("V R O R V"): one SHAKE/RATTLE drift per half-step.
    pub fn baoab() -> Self {
        Self {
            substeps: 1,
            solver: SolverSettings {
                tolerance: DEFAULT_TOLERANCE,
                max_iterations: 50,
                homotopy: false,
                contraction_probes: 0,
                ..SolverSettings::default()
            },
            monitor_velocity_constraint: false,
        }
    }

    /// g-BAOAB with [`G_BAOAB_SUBSTEPS`] geodesic substeps ("V R R R O R R R V").
    pub fn g_baoab() -> Self {
        Self {
            substeps: G_BAOAB_SUBSTEPS,
            ..Self::baoab()
        }
    }

    /// With K_r = `substeps` >= 1 geodesic substeps per A half-step.
    pub fn with_substeps(self, substeps: usize) -> Result<Self, SplittingError> {
        if substeps == 0 {
            return Err(SplittingError::invalid(
                "substeps",
                0.0,
                "a geodesic drift needs at least one substep (K_r >= 1)",
            ));
        }
        Ok(Self { substeps, ..self })
    }

    /// With the SHAKE tolerance on max |g|, finite and in (0, 1e-3].
    pub fn with_tolerance(self, tolerance: f64) -> Result<Self, SplittingError> {
        if !(tolerance > 0.0 && tolerance <= 1e-3) {
            return Err(SplittingError::invalid(
                "projection tolerance",
                tolerance,
                "the SHAKE tolerance on max |g| must lie in (0, 1e-3]",
            ));
        }
        let solver = SolverSettings {
            tolerance,
            // A residual that stagnates above the tolerance is accepted only at roundoff.
            stagnation_tolerance: self.solver.stagnation_tolerance.max(tolerance),
            ..self.solver
        };
        Ok(Self { solver, ..self })
    }

    /// With at most `iterations` >= 1 Newton iterations per projection.
    pub fn with_max_iterations(self, iterations: usize) -> Result<Self, SplittingError> {
        if iterations == 0 {
            return Err(SplittingError::invalid(
                "max_iterations",
                0.0,
                "the SHAKE projection needs at least one Newton iteration",
            ));
        }
        let solver = SolverSettings {
            max_iterations: iterations,
            ..self.solver
        };
        Ok(Self { solver, ..self })
    }

    /// Measures max |Dg(r') v'| after each step.
    pub fn monitored(self) -> Self {
        Self {
            monitor_velocity_constraint: true,
            ..self
        }
    }
}

impl Default for SplittingConfig {
    /// [`SplittingConfig::g_baoab`].
    fn default() -> Self {
        Self::g_baoab()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_out_of_range_are_refused_by_name() {
        let e = SplittingConfig::baoab().with_substeps(0).unwrap_err();
        assert!(e.to_string().contains("substeps"), "{e}");
        for bad in [0.0, -1e-12, 1e-2, f64::NAN] {
            let e = SplittingConfig::baoab().with_tolerance(bad).unwrap_err();
            assert!(e.to_string().contains("projection tolerance"), "{e}");
        }
        assert!(SplittingConfig::baoab().with_max_iterations(0).is_err());
        let c = SplittingConfig::g_baoab().with_tolerance(1e-8).unwrap();
        assert_eq!((c.substeps, c.solver.tolerance), (3, 1e-8));
        assert!(!c.solver.homotopy);
    }
}

/// The sizes of one step of size h: h, the geodesic substep tau = h / (2 K_r), 1 / tau and
/// K_r.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StepSizes {
    pub(crate) h: f64,
    pub(crate) tau: f64,
    pub(crate) inverse_tau: f64,
    pub(crate) substeps: usize,
}

impl StepSizes {
    /// The sizes of a step of h with `config`'s substeps.
    pub(crate) fn new(config: &SplittingConfig, h: f64) -> Self {
        let tau = h / (2 * config.substeps) as f64;
        Self {
            h,
            tau,
            inverse_tau: 1.0 / tau,
            substeps: config.substeps,
        }
    }
}
