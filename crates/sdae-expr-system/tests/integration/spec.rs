//! The specification's forms: serde (JSON here, TOML in scenes) with unknown fields refused;
//! generated coordinate names and masses per particle; the Gram structure from the Jacobian's
//! pattern; the projection of the initial state; quadratic constraints found.

use sdae_expr_system::{ExpressionSpec, ExpressionSystem, MassSpec, NoiseSpec, ShapeVisitor};
use sdae_manifold::{GramShape, GramStructure, Tridiagonal, check_state};
use sdae_model::System;

use crate::{base_spec, double_pendulum, molecule, torus};

#[test]
fn a_spec_reads_from_json_and_refuses_unknown_fields() {
    let text = r#"{
        "particles": 1, "dimension": 2, "mass": 1.0,
        "parameters": {"L": 1.0},
        "constraints": ["(x1^2 + y1^2 - L^2) / 2"],
        "potential": "y1", "friction": 0.5, "kT": 2.0,
        "observables": {"height": "y1"},
        "position": [0.0, -1.0]
    }"#;
    let spec: ExpressionSpec = serde_json::from_str(text).unwrap();
    assert_eq!(spec.kt, Some(2.0));
    let system = ExpressionSystem::compile(&spec).unwrap();
    assert_eq!(system.coordinates(), ["x1", "y1"]);
    assert_eq!(system.initial_state().1, [0.0, 0.0]);
    assert_eq!(system.observable_names(), ["height"]);
    let noise: NoiseSpec = serde_json::from_str(r#"["0.1 * v_x1", "1"]"#).unwrap();
    assert!(matches!(noise, NoiseSpec::Expressions(_)));
    let noise: NoiseSpec = serde_json::from_str("[0.1, 1]").unwrap();
    assert_eq!(noise, NoiseSpec::Intensities(vec![0.1, 1.0]));
    let mass: MassSpec = serde_json::from_str("[1, 2]").unwrap();
    assert_eq!(mass, MassSpec::Each(vec![1.0, 2.0]));
    let bad = text.replace("\"kT\"", "\"temperature\"");
    let error = serde_json::from_str::<ExpressionSpec>(&bad).unwrap_err();
    assert!(
        error.to_string().contains("unknown field `temperature`"),
        "{error}"
    );
    let back: ExpressionSpec =
        serde_json::from_str(&serde_json::to_string(&spec).unwrap()).unwrap();
    assert_eq!(back, spec);
}

#[test]
fn particles_name_their_coordinates_and_take_a_mass_each() {
    let system = ExpressionSystem::compile(&molecule()).unwrap();
    assert_eq!(
        system.coordinates(),
        ["x1", "y1", "z1", "x2", "y2", "z2", "x3", "y3", "z3"]
    );
    let masses = [16.0, 16.0, 16.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
    assert_eq!(system.mass().diagonal(), masses);
    assert_eq!(system.noise_dim(), 9);
    assert_eq!(
        system.langevin(),
        None,
        "a noise per coordinate is not sigma I"
    );
}

/// The structure from the pattern: the double pendulum's rods share the first mass only with
/// their neighbour (tridiagonal), the molecule's bonds share the centre atom (m = 2, also
/// tridiagonal), a triangle of three bonds couples the first and last (dense).
#[test]
fn the_gram_structure_comes_from_the_jacobian_pattern() {
    let structure = |spec: &ExpressionSpec| {
        let system = ExpressionSystem::compile(spec).unwrap();
        system.expression_constraint().structure()
    };
    assert_eq!(structure(&double_pendulum()), GramStructure::Tridiagonal);
    assert_eq!(structure(&torus()), GramStructure::Scalar);
    assert_eq!(structure(&molecule()), GramStructure::Tridiagonal);
    let mut triangle = molecule();
    triangle
        .constraints
        .push("((x3 - x2)^2 + (y3 - y2)^2 + (z3 - z2)^2 - 2.6) / 2".into());
    let b = 0.96f64;
    let side = (2.0 * b * b * (1.0 - 1.8f64.cos())).to_string();
    *triangle.constraints.last_mut().unwrap() =
        format!("((x3 - x2)^2 + (y3 - y2)^2 + (z3 - z2)^2 - {side}) / 2");
    assert_eq!(structure(&triangle), GramStructure::Dense);
    let pendulum = ExpressionSystem::compile(&double_pendulum()).unwrap();
    assert_eq!(
        pendulum.expression_constraint().pattern(),
        [(0, 0), (0, 1), (1, 0), (1, 1), (1, 2), (1, 3)]
    );
    assert!(pendulum.with_shape::<Tridiagonal>().is_some());
    assert!(pendulum.with_shape::<sdae_manifold::Scalar>().is_none());
    struct Structure;
    impl ShapeVisitor for Structure {
        type Output = GramStructure;
        fn visit<Sh: GramShape>(self, _: ExpressionSystem<Sh>) -> GramStructure {
            Sh::STRUCTURE
        }
    }
    assert_eq!(pendulum.visit_shape(Structure), GramStructure::Tridiagonal);
    let torus = ExpressionSystem::compile(&torus()).unwrap();
    assert_eq!(torus.visit_shape(Structure), GramStructure::Scalar);
}

#[test]
fn quadratic_constraints_are_found() {
    let quadratic = |spec: &ExpressionSpec| {
        let system = ExpressionSystem::compile(spec).unwrap();
        system.expression_constraint().is_quadratic()
    };
    assert!(quadratic(&double_pendulum()));
    assert!(quadratic(&molecule()));
    assert!(!quadratic(&torus()));
}

#[test]
fn an_initial_state_is_projected_when_asked() {
    let mut spec = double_pendulum();
    spec.position = vec![0.7, -0.9, 0.9, -1.5];
    spec.velocity = Some(vec![1.0, 0.0, 1.0, 0.5]);
    spec.project = true;
    let system = ExpressionSystem::compile(&spec).unwrap();
    let (r, v) = system.initial_state();
    let residuals = check_state(system.constraint(), r, v, 1e-14).unwrap();
    assert!(
        residuals.position <= 1e-14 && residuals.velocity <= 1e-14,
        "{residuals:?}"
    );
    // The velocity's correction is M-orthogonal to the tangent space: M (v0 - v) = grad g lambda,
    // so for any tangent t, t . M (v0 - v) = 0; the rigid rotation of both rods about the
    // origin, t = J r with the second rod turning with it, is tangent.
    let t = [-r[1], r[0], -r[3], r[2]];
    let given = spec.velocity.unwrap();
    let masses = [1.0, 1.0, 2.0, 2.0];
    let inner: f64 = (0..4).map(|k| t[k] * masses[k] * (given[k] - v[k])).sum();
    assert!(inner.abs() < 1e-13, "{inner}");
    // A point far from the torus projects onto it; a point on its axis (where the
    // constraint's derivative is 0 / 0) is refused, projection or not.
    let mut spec = torus();
    spec.position = vec![4.0, 1.0, -2.0];
    spec.project = true;
    let system = ExpressionSystem::compile(&spec).unwrap();
    let (r, v) = system.initial_state();
    check_state(system.constraint(), r, v, 1e-14).unwrap();
    spec.position = vec![0.0, 0.0, 0.0];
    let error = ExpressionSystem::compile(&spec).unwrap_err();
    assert_eq!(error.key, "constraints[0]");
    assert!(error.to_string().contains("is NaN"), "{error}");
}

#[test]
fn a_system_without_forces_or_noise_has_zero_drift_and_no_noise() {
    let spec = base_spec(&["x", "y"], &["x^2 + y^2 - 1"], &[1.0, 0.0]);
    let system = ExpressionSystem::compile(&spec).unwrap();
    let mut a = [1.0; 2];
    system.drift(&[1.0, 0.0], &[0.0, 2.0], &mut a);
    assert_eq!(a, [0.0, 0.0]);
    assert_eq!(system.noise_dim(), 0);
    let form = system.langevin().unwrap();
    assert_eq!((form.friction, form.noise), (0.0, 0.0));
}

/// A system is shared by threads and cloned cheaply.
#[test]
fn systems_and_observables_are_send_and_sync() {
    fn shared<T: Send + Sync + Clone + std::fmt::Debug + 'static>() {}
    shared::<ExpressionSystem>();
    shared::<ExpressionSystem<Tridiagonal>>();
    shared::<sdae_expr_system::ExpressionObservable>();
    shared::<sdae_expr_system::ExpressionConstraint>();
}

/// Observables evaluated on many threads at once give the one-thread numbers (each thread
/// has its own registers).
#[test]
fn observables_evaluate_on_many_threads() {
    let system = ExpressionSystem::compile(&double_pendulum()).unwrap();
    let energy = system.observable("energy").unwrap();
    let value = |k: usize| {
        let v = [0.1 * k as f64, 0.2, -0.3, 0.4];
        energy.value(system.initial_state().0, &v)
    };
    let expected: Vec<f64> = (0..64).map(value).collect();
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..4)
            .map(|_| s.spawn(|| (0..64).map(value).collect::<Vec<f64>>()))
            .collect();
        for handle in handles {
            assert_eq!(handle.join().unwrap(), expected);
        }
    });
}
