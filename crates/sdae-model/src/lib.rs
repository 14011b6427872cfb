//! What every scheme and every system for constrained stochastic mechanical systems (seed eq.
//! 1.1) shares:
//!
//! ```text
//! dr = v dt,   M dv = a(r, v) dt + B(r, v) dw + grad g(r) dmu,   g(r) = 0
//! ```
//!
//! - the system: [`System`], built from parts ([`Drift`], [`Noise`]) with [`MechanicalSystem`];
//! - the Brownian increments dw that drive it come from [`sdae_noise`]: a path's from any
//!   [`IncrementSource`](sdae_noise::IncrementSource) (its own streams,
//!   [`GaussianIncrements::for_path`](sdae_noise::GaussianIncrements::for_path)), an
//!   ensemble's from [`EnsembleIncrements`](sdae_noise::EnsembleIncrements) (W paths at once,
//!   the same numbers); a [`NoiseError`](sdae_noise::NoiseError) converts into [`ModelError`];
//! - the one step trait [`Scheme`] with its [`StepOutcome`] and [`StepFailure`] (classified by
//!   [`FailureKind`]);
//! - the one path driver [`run_path`] on a [`TimeGrid`] (and [`advance`], a stretch of a path
//!   in progress), reporting to an [`Observer`] such as [`Recorder`] and summarized in
//!   [`PathDiagnostics`];
//! - many paths of one scheme at once: [`PathEnsemble`], with [`LaneEnsemble`] (structure of
//!   arrays, W paths per step in SIMD lanes where the scheme has a lane form, [`LaneScheme`],
//!   with the building blocks of a lane form in [`engine`]; the lanes themselves are those of
//!   [`sdae_lanes`]) and [`PathLoop`] for any scheme;
//! - the tangent bundle: [`project_state`], [`TangentProjector`] and the [`KappaProblem`] of
//!   seed eq. 3.1.
//!
//! A scheme of one's own is a type that implements [`Scheme`]; here the explicit Euler step of
//! a free particle on the unit circle, projected back by [`TangentProjector`]:
//!
//! ```
//! use sdae_ift::SolverSettings;
//! use sdae_manifold::{IdentityMass, ScalarGram, Sphere};
//! use sdae_model::{
//!     MechanicalSystem, NoNoise, NoObserver, Scheme, StepFailure, StepOutcome, StepResult, System,
//!     TangentProjector, TimeGrid, ZeroDrift, run_path,
//! };
//! use sdae_noise::GaussianIncrements;
//!
//! type Circle = MechanicalSystem<Sphere, IdentityMass, ZeroDrift, NoNoise>;
//!
//! struct ProjectedEuler {
//!     system: Circle,
//!     projector: TangentProjector<ScalarGram>,
//! }
//!
//! impl Scheme for ProjectedEuler {
//!     type System = Circle;
//!     fn system(&self) -> &Circle {
//!         &self.system
//!     }
//!     fn step(&mut self, r: &mut [f64], v: &mut [f64], h: f64, _dw: &[f64])
//!         -> StepResult {
//!         let (c, m) = (self.system.constraint(), self.system.mass());
//!         let mut next = r.to_vec();
//!         for (x, vi) in next.iter_mut().zip(v.iter()) {
//!             *x += h * vi;
//!         }
//!         let certificate = self
//!             .projector
//!             .project_position(c, m, &mut next)
//!             .map_err(|source| StepFailure::Root { what: "projection", source })?;
//!         self.projector.project_velocity(c, m, &next, v)?;
//!         r.copy_from_slice(&next);
//!         Ok(StepOutcome { newton_iterations: certificate.iterations, ..StepOutcome::PLAIN })
//!     }
//!     fn multiplier_increment(&self) -> &[f64] {
//!         &[0.0]
//!     }
//! }
//!
//! let system = MechanicalSystem::new(Sphere::new(2, 1.0)?, IdentityMass, ZeroDrift, NoNoise)?;
//! let projector = TangentProjector::new(system.constraint(), SolverSettings::default());
//! let mut scheme = ProjectedEuler { system, projector };
//! let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 1.0]);
//! let grid = TimeGrid::new(1.0, 100)?;
//! let mut noise = GaussianIncrements::for_path(1, 0, 0);
//! let diagnostics = run_path(&mut scheme, &mut r, &mut v, grid, &mut noise, &mut NoObserver)?;
//! assert!(diagnostics.max_position_residual < 1e-12);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod constrained;
mod diagnostics;
mod driver;
mod ensemble;
mod error;
mod grid;
mod kernel_lanes;
mod kernel_scheme;
mod lane_diagnostics;
mod lane_ensemble;
mod newton_lanes;
mod newton_root;
mod observer;
mod one_lane;
mod scheme;
mod sphere_lanes;
mod sphere_root;
mod system;
mod tangent;

pub use constrained::{UpdateBuffers, constrained_update};
pub use diagnostics::{ITERATION_BINS, PathDiagnostics, PathFailure, TRUNCATION_DOMINATED};
pub use driver::{INITIAL_STATE_TOLERANCE, PathState, Steps, advance, run_path};
pub use ensemble::{PathEnsemble, PathLoop, check_initial_state, check_path};
pub use error::{FailureKind, ModelError, StepError, StepFailure, check_dim, check_step_size};
pub use grid::TimeGrid;
pub use kernel_scheme::{
    Constrained, KernelNext, KernelOutcome, KernelScheme, KernelState, Kernelized, StepKernel,
};
pub use lane_ensemble::{LaneEnsemble, LaneScheme};
pub use observer::{Interpolation, NoObserver, Observer, Recorder};
pub use scheme::{Scheme, StepOutcome, StepResult};
pub use system::{
    AdditiveNoise, ClosureNoise, Drift, LangevinForm, MechanicalSystem, NoNoise, Noise, System,
    ZeroDrift, add_noise_over_lanes, check_dimensions, check_step_input, drift_over_lanes,
};
pub use tangent::{KappaProblem, TangentProjector, lambda_right_hand_side, project_state};

/// The building blocks of a scheme's lane form (what [`LaneScheme`] implementations are written
/// with): the paths' layout ([`LanePaths`](engine::LanePaths), [`LaneRows`](engine::LaneRows)),
/// a group of lanes in a step ([`GroupState`](engine::GroupState), [`LaneStep`](engine::LaneStep)),
/// the kernels ([`LaneKernel`](engine::LaneKernel) at a fixed width, [`WideKernel`](engine::WideKernel)
/// over an instruction set), the per-lane diagnostics ([`LaneRecord`](engine::LaneRecord)), the
/// buffers a scheme keeps for them ([`LaneStore`](engine::LaneStore)) and the kappa root in
/// lanes: in closed form on a sphere ([`SphereRoot`](engine::SphereRoot),
/// [`RootLanes`](engine::RootLanes)), by Newton for a constraint's lane formulas
/// ([`NewtonRoot`](engine::NewtonRoot), [`NewtonLanes`](engine::NewtonLanes) at
/// [`Drifted`](engine::Drifted)), and the way a scheme steps such a constraint's paths
/// ([`NewtonKernels`](engine::NewtonKernels), [`step_newton_lanes`](engine::step_newton_lanes)).
pub mod engine {
    pub use crate::lane_diagnostics::LaneRecord;
    pub use crate::lane_ensemble::{
        GroupState, LaneKernel, LanePaths, LaneRows, LaneStep, LaneStore, StepInput, WideKernel,
    };
    pub use crate::newton_lanes::{NewtonKernels, step_newton_lanes, step_offered_newton_lanes};
    pub use crate::newton_root::{Drifted, NewtonLanes, NewtonRoot, build_lane_form};
    pub use crate::one_lane::{OneLaneRoot, OneLaneStep, step_one_lane};
    pub use crate::sphere_lanes::{SPHERE_LANES_MAX_DIM, SphereKernels, step_sphere_lanes};
    pub use crate::sphere_root::{RootLanes, SphereRoot};
}
