//! The scheme's constants: truncation C_eta (seed eq. 3.2), ball radius C_kappa (Thm 3.4) and
//! the root solver's settings.

use sdae_ift::SolverSettings;
use sdae_manifold::TheoryBound;

use crate::error::SchemeError;
use sdae_model::System;

/// Constants and settings of the half-explicit drift-truncated Euler stepper.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepperConfig {
    /// C_eta of eq. 3.2; `None` for the untruncated scheme (eta = 1).
    pub c_eta: Option<f64>,
    /// Radius C_kappa of the ball the kappa root must lie in (may be infinite).
    pub c_kappa: f64,
    /// Settings of the kappa solver.
    pub solver: SolverSettings,
    /// Measure |Dg(r') v'| after every step (one extra O(n) product).
    pub monitor_velocity_constraint: bool,
    /// Scale the Brownian increment of a truncated step by sqrt(eta) along with the drift, so
    /// that the step is in law an untruncated step of size eta h (beyond the seed, whose
    /// truncation damps the drift, friction included, but not the noise, and so heats Langevin
    /// runs). Off by default: the seed's scheme.
    pub rescale_noise: bool,
    /// Measure the step's size on each constraint's own length scale
    /// ([`Constraint::local_motion`](sdae_manifold::Constraint::local_motion): the relative
    /// speed of neighbouring beads per segment length, say) instead of the seed's
    /// max(|v|, |v|^2, |a|) of all coordinates together (beyond the seed; the same for a unit
    /// sphere). Off by default: the seed's scheme.
    pub local_size: bool,
}

fn positive(name: &'static str, value: f64) -> Result<f64, SchemeError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(SchemeError::invalid(name, value, "must be finite and > 0"))
    }
}

impl StepperConfig {
    /// The theory's constants C_eta = 1/(4 C_g^3), C_kappa = 1/(8 C_g^4) (Thm 3.4).
    pub fn theory(c_g: f64) -> Result<Self, SchemeError> {
        if !(c_g.is_finite() && c_g >= 1.0) {
            return Err(SchemeError::invalid(
                "C_g",
                c_g,
                "C_g of eq. 2.2 is finite and >= 1",
            ));
        }
        Ok(Self {
            c_eta: Some(1.0 / (4.0 * c_g.powi(3))),
            c_kappa: 1.0 / (8.0 * c_g.powi(4)),
            solver: SolverSettings::default(),
            monitor_velocity_constraint: true,
            rescale_noise: false,
            local_size: false,
        })
    }

    /// The theory's constants for a system whose constraint bounds C_g.
    pub fn for_system<S>(system: &S) -> Result<Self, SchemeError>
    where
        S: System,
        S::Constraint: TheoryBound,
    {
        let c_g = system
            .constraint()
            .c_g(system.mass())
            .ok_or(SchemeError::NoTheoryBound)?;
        Self::theory(c_g)
    }

    /// Explicit constants; `c_kappa` may be `f64::INFINITY`.
    pub fn new(c_eta: f64, c_kappa: f64) -> Result<Self, SchemeError> {
        let c_kappa = if c_kappa == f64::INFINITY {
            c_kappa
        } else {
            positive("C_kappa", c_kappa)?
        };
        Ok(Self {
            c_eta: Some(positive("C_eta", c_eta)?),
            c_kappa,
            solver: SolverSettings::default(),
            monitor_velocity_constraint: true,
            rescale_noise: false,
            local_size: false,
        })
    }

    /// Sets C_eta (the theory value is very conservative; see design notes Section 6).
    pub fn with_c_eta(mut self, c_eta: f64) -> Result<Self, SchemeError> {
        self.c_eta = Some(positive("C_eta", c_eta)?);
        Ok(self)
    }

    /// Sets C_kappa (`f64::INFINITY` leaves only the plausibility check of the solver).
    pub fn with_c_kappa(mut self, c_kappa: f64) -> Result<Self, SchemeError> {
        self.c_kappa = if c_kappa == f64::INFINITY {
            c_kappa
        } else {
            positive("C_kappa", c_kappa)?
        };
        Ok(self)
    }

    /// The same constants with the noise of a truncated step scaled by sqrt(eta) (see
    /// [`StepperConfig::rescale_noise`]; beyond the seed).
    pub fn rescaled(mut self) -> Self {
        self.rescale_noise = true;
        self
    }

    /// The same constants with the local size functional (see [`StepperConfig::local_size`];
    /// beyond the seed).
    pub fn local(mut self) -> Self {
        self.local_size = true;
        self
    }

    /// The untruncated half-explicit Euler scheme (eta = 1), for comparison. No theorem gives a
    /// ball for it, so C_kappa becomes infinite and only the solver's plausibility check remains.
    pub fn untruncated(mut self) -> Self {
        self.c_eta = None;
        self.c_kappa = f64::INFINITY;
        self
    }

    /// Sets the kappa solver's settings.
    pub fn with_solver(mut self, solver: SolverSettings) -> Result<Self, SchemeError> {
        positive("solver tolerance", solver.tolerance)?;
        positive("solver min_tau_step", solver.min_tau_step)?;
        if solver.stagnation_tolerance.is_nan() || solver.stagnation_tolerance < solver.tolerance {
            return Err(SchemeError::invalid(
                "solver stagnation_tolerance",
                solver.stagnation_tolerance,
                "must be >= the solver tolerance",
            ));
        }
        if solver.max_iterations == 0 {
            return Err(SchemeError::invalid(
                "solver max_iterations",
                0.0,
                "must be >= 1",
            ));
        }
        if solver.plausibility_factor.is_nan() || solver.plausibility_factor < 1.0 {
            return Err(SchemeError::invalid(
                "solver plausibility_factor",
                solver.plausibility_factor,
                "must be >= 1 (infinity disables the check)",
            ));
        }
        if solver.max_contraction.is_nan() || solver.max_contraction <= 0.0 {
            return Err(SchemeError::invalid(
                "solver max_contraction",
                solver.max_contraction,
                "must be > 0 (infinity disables the check; the theorem needs < 1/2)",
            ));
        }
        self.solver = solver;
        Ok(self)
    }

    /// Checks every constant and setting (what the setters check, for a config built by hand).
    pub fn validate(&self) -> Result<(), SchemeError> {
        if let Some(c_eta) = self.c_eta {
            positive("C_eta", c_eta)?;
        }
        if self.c_kappa != f64::INFINITY {
            positive("C_kappa", self.c_kappa)?;
        }
        self.with_solver(self.solver).map(|_| ())
    }

    /// Switches the |Dg(r') v'| measurement on or off.
    pub fn with_velocity_monitor(mut self, on: bool) -> Self {
        self.monitor_velocity_constraint = on;
        self
    }
}
