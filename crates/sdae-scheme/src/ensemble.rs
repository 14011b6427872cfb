//! The ensemble engine of the half-explicit scheme: [`Ensemble`].

mod newton;
pub(crate) mod sphere;

use sdae_lanes::LaneWidth;
use sdae_model::engine::{LanePaths, StepInput, step_offered_newton_lanes};
use sdae_model::{LaneEnsemble, LaneScheme, System};

use crate::stepper::Stepper;

/// P paths of one system and the scalar stepper that decides what the lanes do not.
///
/// Many independent paths of one system, stepped together in SIMD lanes (seed eq. 3.1, 3.2).
///
/// An [`Ensemble`] is the [`LaneEnsemble`] of a [`Stepper`] (a
/// [`PathEnsemble`](sdae_model::PathEnsemble)): it holds P paths in structure-of-arrays layout
/// ([`LanePaths`]: block by block of [`LANE_BLOCK`](sdae_lanes::LANE_BLOCK) paths; the
/// increments of a step with coordinate j of path p at `j * stride + p`, stride =
/// [`lane_stride`](sdae_lanes::lane_stride)`(P)`) and advances W of them at once, W the width of the instruction set chosen at run time ([`LaneWidth`]): 1
/// (scalar), 4 (AVX2) or 8 (AVX-512). For a sphere constraint (the pendulums) with a diagonal
/// mass the step is the closed form of [`Stepper`] written once over [`Lanes`](sdae_lanes::Lanes) (which
/// [`Stepper`]'s own step of one path runs at W = 1), with the
/// system's drift and noise over lanes ([`System::drift`], [`System::add_noise`], written once
/// over `Real`; a user's closures are evaluated path by path within the lanes, which gives
/// the same numbers); a lane the closed form does not decide (no root, a
/// root outside the ball or not contracting, a non-finite value) finishes its step through the
/// scalar [`Stepper`], which reports the failure exactly as for one path. For a constraint
/// that offers its formulas over lanes ([`Constraint::lane_form`](sdae_manifold::Constraint::lane_form) with a
/// [`Equations`](sdae_manifold::Equations): a bead chain ([`BeadChain`](sdae_manifold::BeadChain): the chain
/// molecule, the fiber), rigid bonds ([`RigidBonds`](sdae_manifold::RigidBonds) of up to
/// [`DENSE_FAER_THRESHOLD`](sdae_manifold::DENSE_FAER_THRESHOLD) bonds: the rigid triatomic,
/// any bond network), or a user's constraint, as in `examples/custom_constraint.rs`) with a
/// diagonal mass the step is Newton for kappa with a convergence mask per lane and the
/// solver's certificate, written once for all of them, over lanes of any length:
/// Thomas' algorithm for the chain's tridiagonal Newton matrix, an LU factorization with
/// partial pivoting per lane for the bonds' dense one, 1 / A for one equation (the fiber's and the Langevin molecules'
/// forces and noise have lane forms too). A lane Newton does not decide (no convergence, a
/// pivot the factorization rejects, a root the certificate rejects, a non-finite value)
/// finishes its step through the scalar [`Stepper`], with its homotopy fallback. A decided
/// lane's numbers are the scalar step's, bit for bit. Any other constraint (or mass) steps its
/// paths one at a time through the scalar [`Stepper`].
///
/// Lane p computes exactly what a lane of any other width computes: a path's numbers do not
/// depend on W, on the other paths or on how paths are split across ensembles or threads.
///
/// ```
/// use sdae_model::PathEnsemble;
/// use sdae_noise::EnsembleIncrements;
/// use sdae_scheme::{Ensemble, Stepper, StepperConfig};
/// use sdae_systems::{PendulumParams, pendulum};
/// let system = pendulum(PendulumParams::default())?;
/// let config = StepperConfig::for_system(&system)?.with_c_eta(1.0)?;
/// let mut ensemble = Ensemble::new(Stepper::new(system, config)?, 100, &[1.0, 0.0], &[0.0, 0.5])?;
/// // Path p's increments from its own stream (seed 7, index p), drawn W paths at once.
/// let indices: Vec<u64> = (0..100).collect();
/// let mut noise = EnsembleIncrements::for_paths(7, &indices, 2);
/// let h = 1e-3;
/// let mut dw = vec![0.0; 2 * ensemble.stride()];
/// for _ in 0..1000 {
///     noise.fill(h, &mut dw)?;
///     ensemble.step(h, &dw)?;
/// }
/// assert_eq!(ensemble.failed_paths(), 0);
/// let (mut r, mut v, mut mu) = ([0.0; 2], [0.0; 2], [0.0; 1]);
/// ensemble.state(17, &mut r, &mut v, &mut mu)?;
/// assert!((r[0] * r[0] + r[1] * r[1] - 1.0).abs() < 1e-12);
/// assert_eq!(ensemble.diagnostics(17)?.steps, 1000);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// Sixteen chain molecules (8 atoms, 7 rigid bonds) under Langevin dynamics, stepped in lanes:
///
/// ```
/// use sdae_manifold::{Constraint, Mass};
/// use sdae_model::{PathEnsemble, System};
/// use sdae_noise::EnsembleIncrements;
/// use sdae_scheme::{Ensemble, Stepper, StepperConfig};
/// use sdae_systems::{ChainMoleculeParams, chain_molecule};
/// let molecule = chain_molecule(&ChainMoleculeParams::default())?;
/// let (r0, v0) = molecule.initial_state();
/// let l = molecule.noise_dim();
/// let config = StepperConfig::for_system(&molecule)?
///     .with_c_eta(1.0)?
///     .with_c_kappa(f64::INFINITY)?;
/// let mut ensemble = Ensemble::new(Stepper::new(molecule, config)?, 16, &r0, &v0)?;
/// let indices: Vec<u64> = (0..16).collect();
/// let mut noise = EnsembleIncrements::for_paths(3, &indices, l);
/// let (h, mut dw) = (1e-3, vec![0.0; l * ensemble.stride()]);
/// for _ in 0..200 {
///     noise.fill(h, &mut dw)?;
///     ensemble.step(h, &dw)?;
/// }
/// // Every step decided in lanes, every bond still of length 1.
/// assert_eq!((ensemble.failed_paths(), ensemble.scalar_steps()), (0, 0));
/// let (mut r, mut v, mut mu) = (vec![0.0; 24], vec![0.0; 24], vec![0.0; 7]);
/// ensemble.state(9, &mut r, &mut v, &mut mu)?;
/// let mut g = vec![0.0; 7];
/// ensemble.system().constraint().value(&r, &mut g);
/// assert!(g.iter().all(|gi| gi.abs() < 1e-12));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub type Ensemble<S> = LaneEnsemble<Stepper<S>>;

/// The closed form of a sphere, or Newton for a constraint that offers formulas over lanes
/// (the bead chain, rigid bonds, a user's constraint), with a diagonal mass
/// ([`Constraint::lane_form`](sdae_manifold::Constraint::lane_form)); `false` (every path through the scalar step) for any other
/// constraint or mass.
impl<S: System> LaneScheme for Stepper<S> {
    /// The sphere's closed form in lanes (`ensemble/sphere.rs`) where the constraint is a
    /// sphere, Newton with its formulas over lanes where it offers them
    /// ([`step_offered_newton_lanes`] with the kernel of `newton.rs`); `false` otherwise.
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool {
        let input = StepInput { h, dw };
        sphere::step_all(self, paths, width, input)
            || step_offered_newton_lanes(self, paths, width, input)
    }
}
