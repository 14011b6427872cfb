//! [`ExpressionSystem`]: a specification compiled once into a system the schemes step.

use std::collections::BTreeMap;
use std::sync::Arc;

use sdae_expr::{Graph, SymbolTable};
use sdae_lanes::Real;
use sdae_manifold::{Dense, DiagonalMass, GramShape, GramStructure, Scalar, Tridiagonal};
use sdae_model::{LangevinForm, System};

use crate::constraint::{ConstraintPrograms, ExpressionConstraint};
use crate::dynamics::Dynamics;
use crate::error::SpecError;
use crate::initial::initial_state;
use crate::names::{coordinates, masses, symbol_table};
use crate::observable::{ExpressionObservable, compile_all};
use crate::spec::ExpressionSpec;

/// What a compiled system holds besides its constraint, shared by its clones.
#[derive(Debug)]
struct Parts {
    coordinates: Vec<String>,
    mass: DiagonalMass,
    dynamics: Dynamics,
    observables: BTreeMap<String, ExpressionObservable>,
    table: SymbolTable,
    position: Vec<f64>,
    velocity: Vec<f64>,
}

/// A constrained stochastic mechanical system compiled from an [`ExpressionSpec`]: the
/// constraint's programs ([`ExpressionConstraint`]), the diagonal mass, the drift
/// -grad V + a(q, v) - gamma v and the noise, evaluated over any [`Real`], with the named
/// observables and the checked (or projected) initial state. Cloning shares the programs.
///
/// `Sh` is the structure of the Gram matrix the engines factor ([`ExpressionConstraint`]);
/// [`ExpressionSystem::compile`] gives [`Dense`] (right for every system),
/// [`ExpressionSystem::visit_shape`] the narrowest the Jacobian's pattern allows.
pub struct ExpressionSystem<Sh: GramShape = Dense> {
    parts: Arc<Parts>,
    constraint: ExpressionConstraint<Sh>,
}

impl<Sh: GramShape> Clone for ExpressionSystem<Sh> {
    fn clone(&self) -> Self {
        Self {
            parts: self.parts.clone(),
            constraint: self.constraint.clone(),
        }
    }
}

impl<Sh: GramShape> std::fmt::Debug for ExpressionSystem<Sh> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExpressionSystem")
            .field("coordinates", &self.parts.coordinates)
            .field("constraint", &self.constraint)
            .field("mass", &self.parts.mass)
            .field("dynamics", &self.parts.dynamics)
            .field("observables", &self.observable_names())
            .finish()
    }
}

/// What [`ExpressionSystem::visit_shape`] hands the system to, with its Gram structure as a
/// type.
pub trait ShapeVisitor {
    /// What the visitor makes of the system.
    type Output;
    /// The system with the narrowest Gram structure its constraint allows.
    fn visit<Sh: GramShape>(self, system: ExpressionSystem<Sh>) -> Self::Output;
}

impl ExpressionSystem {
    /// Compiles `spec`: names bound, expressions parsed, differentiated and compiled, the
    /// initial state checked (or projected where `spec.project`). Every refusal names its
    /// entry ([`SpecError::key`]).
    pub fn compile(spec: &ExpressionSpec) -> Result<Self, SpecError> {
        let (names, particles) = coordinates(spec)?;
        let n = names.len();
        let m = spec.constraints.len();
        if m == 0 || m >= n {
            let message = format!(
                "{m} constraints given for {n} coordinates: a system needs 1 <= m < n equations"
            );
            return Err(SpecError::conflict("constraints", message));
        }
        let table = symbol_table(spec, &names, m)?;
        let mass = masses(&spec.mass, n, particles)?;
        let mut graph = Graph::new();
        let programs = ConstraintPrograms::new(&mut graph, &table, &spec.constraints, &names)?;
        let dynamics = Dynamics::new(&mut graph, &table, spec, &names)?;
        let observables = compile_all(&table, &spec.observables)?;
        let (position, velocity) = initial_state(spec, &programs, &mass)?;
        let parts = Parts {
            coordinates: names,
            mass,
            dynamics,
            observables,
            table,
            position,
            velocity,
        };
        Ok(Self {
            parts: Arc::new(parts),
            constraint: ExpressionConstraint::of(Arc::new(programs)),
        })
    }

    /// Hands `visitor` this system with the narrowest Gram structure its constraint allows
    /// ([`ExpressionConstraint::structure`]): [`Scalar`] for one equation, [`Tridiagonal`]
    /// where only neighbouring equations share a coordinate, [`Dense`] otherwise.
    pub fn visit_shape<V: ShapeVisitor>(self, visitor: V) -> V::Output {
        match self.constraint.structure() {
            GramStructure::Scalar => visitor.visit(self.reshaped::<Scalar>()),
            GramStructure::Tridiagonal => visitor.visit(self.reshaped::<Tridiagonal>()),
            GramStructure::Dense => visitor.visit(self),
        }
    }
}

impl<Sh: GramShape> ExpressionSystem<Sh> {
    /// This system with Gram structure `S`, if its constraint allows it (any for `Dense`;
    /// `Tridiagonal` where only neighbouring equations share a coordinate; `Scalar` for one
    /// equation).
    pub fn with_shape<S: GramShape>(&self) -> Option<ExpressionSystem<S>> {
        let allowed = match S::STRUCTURE {
            GramStructure::Dense => true,
            GramStructure::Tridiagonal => self.constraint.structure() != GramStructure::Dense,
            GramStructure::Scalar => self.constraint.structure() == GramStructure::Scalar,
        };
        allowed.then(|| self.reshaped())
    }

    /// The same system with shape `S` (unchecked).
    fn reshaped<S: GramShape>(&self) -> ExpressionSystem<S> {
        ExpressionSystem {
            parts: self.parts.clone(),
            constraint: ExpressionConstraint::of(self.constraint.programs.clone()),
        }
    }

    /// The coordinates' names, in order.
    pub fn coordinates(&self) -> &[String] {
        &self.parts.coordinates
    }

    /// The initial state (r0, v0): on the tangent bundle within
    /// [`DEFAULT_STATE_TOLERANCE`](sdae_manifold::DEFAULT_STATE_TOLERANCE), projected there
    /// if the spec asked.
    pub fn initial_state(&self) -> (&[f64], &[f64]) {
        (&self.parts.position, &self.parts.velocity)
    }

    /// The names of the spec's observables, sorted.
    pub fn observable_names(&self) -> Vec<&str> {
        self.parts.observables.keys().map(String::as_str).collect()
    }

    /// Observable `name` of the spec.
    pub fn observable(&self, name: &str) -> Option<ExpressionObservable> {
        self.parts.observables.get(name).cloned()
    }

    /// Compiles a further observable f(q, v) given as text (refusals under the key
    /// `"observable"`).
    pub fn compile_observable(&self, text: &str) -> Result<ExpressionObservable, SpecError> {
        ExpressionObservable::compile(&self.parts.table, "observable", text)
    }

    /// The constraint g.
    pub fn expression_constraint(&self) -> &ExpressionConstraint<Sh> {
        &self.constraint
    }

    /// The diagonal mass M.
    pub fn diagonal_mass(&self) -> &DiagonalMass {
        &self.parts.mass
    }

    /// out = a(r, v) = -grad V(r) + a_forces(r, v) - gamma v, for one path or W paths.
    #[inline(always)]
    pub fn evaluate_drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) {
        self.parts.dynamics.drift(r, v, out);
    }

    /// The dimension of the Brownian motion: n, or 0 without noise.
    pub fn brownian_dim(&self) -> usize {
        self.parts.dynamics.noise_dim()
    }

    /// out += B(r, v) dw, for one path or W paths.
    #[inline(always)]
    pub fn evaluate_noise<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) {
        self.parts.dynamics.add_noise(r, v, dw, out);
    }

    /// The Langevin form: where the forces do not read the velocities and B = sigma I (or 0),
    /// a(r, v) = F(r) - gamma v with sigma = sqrt(2 gamma kT) when friction and kT are given.
    pub fn langevin_form(&self) -> Option<LangevinForm> {
        let (friction, noise) = self.parts.dynamics.langevin()?;
        Some(LangevinForm { friction, noise })
    }
}

impl<Sh: GramShape> System for ExpressionSystem<Sh> {
    type Constraint = ExpressionConstraint<Sh>;
    type Mass = DiagonalMass;
    fn constraint(&self) -> &ExpressionConstraint<Sh> {
        &self.constraint
    }
    fn mass(&self) -> &DiagonalMass {
        &self.parts.mass
    }
    /// The compiled drift over any number type: always evaluated in lanes.
    #[inline(always)]
    fn drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) -> bool {
        self.evaluate_drift(r, v, out);
        true
    }
    fn noise_dim(&self) -> usize {
        self.brownian_dim()
    }
    #[inline(always)]
    fn add_noise<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) -> bool {
        self.evaluate_noise(r, v, dw, out);
        true
    }
    fn langevin(&self) -> Option<LangevinForm> {
        self.langevin_form()
    }
}
