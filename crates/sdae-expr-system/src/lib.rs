//! A constrained stochastic mechanical system written as expressions, without Rust:
//!
//! ```text
//! dr = v dt
//! M dv = [-grad V(r) + a(r, v) - gamma v] dt + B(r, v) dw + grad g(r) dmu
//! g(r) = 0
//! ```
//!
//! An [`ExpressionSpec`] (a scene file's `[system.expressions]` table, a Python dict) names the
//! coordinates, the masses, parameters, the constraints g_i(q) = 0, a potential V(q), forces
//! a_i(q, v), friction with a temperature or a noise, observables f(q, v) and the initial
//! state. [`ExpressionSystem::compile`] parses every expression ([`sdae_expr`]), differentiates
//! it symbolically (the force -grad V; the Jacobian Dg with its sparsity pattern; Dg u,
//! Dg^T z and D^2 g(u, w)), simplifies and compiles it once into tapes evaluated over any
//! [`sdae_lanes::Real`]: one path in `f64`, or W paths in SIMD lanes with the same bits.
//!
//! ```
//! use std::collections::BTreeMap;
//! use sdae_expr_system::{ExpressionSpec, ExpressionSystem, MassSpec, NoiseSpec};
//!
//! // A double pendulum in the plane under gravity, with additive noise.
//! let spec = ExpressionSpec {
//!     coordinates: Some(["x1", "y1", "x2", "y2"].map(String::from).to_vec()),
//!     particles: None,
//!     dimension: None,
//!     mass: MassSpec::Each(vec![1.0, 1.0, 2.0, 2.0]),
//!     parameters: BTreeMap::from([("L".into(), 1.0), ("c".into(), 9.81)]),
//!     constraints: vec![
//!         "(x1^2 + y1^2 - L^2) / 2".into(),
//!         "((x2 - x1)^2 + (y2 - y1)^2 - L^2) / 2".into(),
//!     ],
//!     potential: Some("c * (y1 + 2 * y2)".into()),
//!     forces: None,
//!     friction: None,
//!     kt: None,
//!     noise: Some(NoiseSpec::Intensity(0.5)),
//!     observables: BTreeMap::from([("height".into(), "y2".into())]),
//!     position: vec![1.0, 0.0, 1.0, -1.0],
//!     velocity: None,
//!     project: false,
//! };
//! let system = ExpressionSystem::compile(&spec)?;
//!
//! // The drift: gravity on each mass (no velocity-dependent force, no friction).
//! let (r, v) = system.initial_state();
//! let mut a = [0.0; 4];
//! system.evaluate_drift(r, v, &mut a);
//! assert_eq!(a, [0.0, -9.81, 0.0, -2.0 * 9.81]);
//!
//! // The constraint: Dg u, and the structure of Dg M^-1 Dg^T from the pattern of Dg.
//! let g = system.expression_constraint();
//! let mut normal = [0.0; 2];
//! g.jacobian_mul(r, &[0.0, 1.0, 0.0, 0.0], &mut normal);
//! assert_eq!(normal, [0.0, 1.0]);
//! assert_eq!(g.structure(), sdae_manifold::GramStructure::Tridiagonal);
//! assert!(g.is_quadratic());
//!
//! // Observables by name, or compiled from text later.
//! assert_eq!(system.observable("height").unwrap().value(r, v), -1.0);
//! let energy = system.compile_observable("(v_x1^2 + v_y1^2) / 2 + v_x2^2 + v_y2^2")?;
//! assert_eq!(energy.value(r, &[1.0, 0.0, 0.0, 0.0]), 0.5);
//!
//! // A refusal names the entry and shows where.
//! let mut bad = spec.clone();
//! bad.constraints[1] = "(x2 - x1)^2 + (y2 - y1)^2 - Lx^2".into();
//! let error = ExpressionSystem::compile(&bad).unwrap_err();
//! assert_eq!(error.key, "constraints[1]");
//! assert!(error.to_string().contains("unknown symbol `Lx`; did you mean `L`?"));
//! # Ok::<(), sdae_expr_system::SpecError>(())
//! ```
//!
//! # The specification
//!
//! - Coordinates: `coordinates` names them, or `particles` and `dimension` (1 to 3) generate
//!   x1, y1, z1, x2, ... Each coordinate's velocity is `v_<name>` in expressions; time `t` is
//!   not available; names beginning with `v_` are reserved.
//! - `mass`: one number, one per coordinate or one per particle (all finite and > 0).
//! - `constraints`: m expressions g_i(q), 1 <= m < n, of the coordinates only.
//! - `potential` V(q) (force -grad V, differentiated symbolically) and `forces`, one
//!   expression a_i(q, v) per coordinate.
//! - `friction` gamma and `kT` together make a Langevin system: drift -gamma v, noise
//!   sqrt(2 gamma kT) I ([`sdae_model::LangevinForm`], for BAOAB and g-BAOAB). Without them,
//!   `noise` is sigma I (a number), diag(sigma_i) (numbers) or diag(b_i(q, v)) (expressions:
//!   multiplicative).
//! - `observables`: named expressions f(q, v); more from text with
//!   [`ExpressionSystem::compile_observable`].
//! - `position` and `velocity` (default 0): refused off the manifold or its tangent space
//!   beyond [`sdae_manifold::DEFAULT_STATE_TOLERANCE`] (the residual named), or projected there
//!   with `project = true` (Newton on g = 0 along M^-1 grad g, then the M-orthogonal
//!   projection of v0).
//!
//! # What is derived
//!
//! The Jacobian's sparsity pattern gives the structure of the Gram matrix Dg M^-1 Dg^T
//! ([`ExpressionConstraint::structure`]): scalar for one equation, tridiagonal where only
//! neighbouring equations share a coordinate (a chain of bonds written in order), dense
//! otherwise; [`ExpressionSystem::visit_shape`] hands the system on with it as a type. A
//! constraint whose second derivative D^2 g does not depend on q is quadratic
//! ([`ExpressionConstraint::is_quadratic`]): with one equation the kappa root is then taken in
//! closed form. Its rounding floor is stated from its constant Hessian. What a step builds from
//! g (g with the cross Gram matrix Dg(x) M^-1 Dg(r)^T over the coordinates each pair of rows
//! shares, the Gram matrix alone, the kappa coefficients of one quadratic equation) is compiled
//! as one program each, for a diagonal M^-1 read as an input and for M = I, with the numbers of
//! the composition of Dg u and Dg^T z (`sdae_manifold::Equations`' provided methods): one call
//! where the composition takes several.
//!
//! # Evaluation
//!
//! A program of a few registers (a pendulum's) runs on an array on the caller's stack; a
//! larger one on registers lent by a per-thread pool (per number type, a few buffers kept
//! between calls): no heap allocation per call once a thread has evaluated each program once,
//! no `unsafe`, and the tape runs in the caller's frame, so over lanes it is compiled with the
//! caller's instruction set. A force that is constant (a uniform field's -grad V) is stored as
//! its values and not evaluated.
//!
//! # Limits
//!
//! Refused beyond them, naming the entry: [`MAX_COORDINATES`] coordinates (with their
//! velocities and the parameters within [`sdae_expr::MAX_SYMBOLS`] names), m < n constraints,
//! [`MAX_OBSERVABLES`] observables, and the limits of [`sdae_expr`] on each expression (text,
//! nesting, nodes) and on the compiled programs. A Jacobian of rank below m at the initial
//! position is refused with its rank (pivots below [`RANK_TOLERANCE`] times its largest entry
//! count as zero).

mod constraint;
mod dynamics;
mod error;
mod fused;
mod initial;
mod names;
mod observable;
mod scratch;
mod spec;
mod system;

pub use constraint::ExpressionConstraint;
pub use error::{SHOWN_CHARS, SpecError, SpecErrorKind};
pub use initial::RANK_TOLERANCE;
pub use names::{MAX_COORDINATES, MAX_OBSERVABLES};
pub use observable::ExpressionObservable;
pub use spec::{ExpressionSpec, MassSpec, NoiseSpec};
pub use system::{ExpressionSystem, ShapeVisitor};
