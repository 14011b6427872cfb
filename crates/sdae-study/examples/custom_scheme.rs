//! Bring your own scheme, and your own system, to a convergence study.
//!
//! The scheme is defined here: a projected symplectic Euler step (momentum first, then the
//! position with the new velocity, projected back onto the manifold along its normal line and
//! the velocity made tangent). It runs side by side with the built-in schemes on
//!
//! - the seed's stochastic pendulum (a built-in scene), and
//! - a particle on an ellipse x^2/a^2 + y^2/b^2 = 1, defined here by closures, under gravity
//!   and additive noise.
//!
//! Run with `cargo run --release -p sdae-study --example custom_scheme`; it prints the observed
//! strong orders of every scheme and writes the reports under `target/custom-scheme/`.

use std::path::Path;

use sdae_ift::SolverSettings;
use sdae_manifold::{ClosureConstraint, Constraint, IdentityMass, Mass};
use sdae_model::{
    AdditiveNoise, MechanicalSystem, Scheme, StepFailure, StepOutcome, StepResult, System,
    TangentProjector, check_step_input,
};
use sdae_reference::CurvedSystem;
use sdae_study::convergence::{
    ConvergenceReport, ConvergenceSettings, build_report, run_convergence_on,
};
use sdae_study::integrator::{SchemeKind, StudyScheme};
use sdae_study::output::{describe_fit, write_report};
use sdae_study::parallel::Control;
use sdae_study::scene::{Output, Prepared, Scene, SceneRunner};

/// Projected symplectic Euler for M dv = a dt + B dw + grad g dmu, g(r) = 0:
///
/// ```text
/// v~ = v + M^-1 [a(r, v) h + B(r, v) dw]
/// r' = r + h v~ + M^-1 grad g(r + h v~) gamma,   g(r') = 0
/// v' = (r' - r) / h, made tangent at r' (M-orthogonal projection)
/// ```
///
/// It does not approximate the multiplier mu: its increment is reported as 0, and the studies
/// below compare r and v only.
struct ProjectedSymplecticEuler<S: System> {
    system: S,
    projector: TangentProjector<<S::Constraint as Constraint>::Gram>,
    force: Vec<f64>,
    next_r: Vec<f64>,
    next_v: Vec<f64>,
    dmu: Vec<f64>,
}

impl<S: System> ProjectedSymplecticEuler<S> {
    fn new(system: S) -> Self {
        let c = system.constraint();
        let (n, m) = (c.dim(), c.n_constraints());
        Self {
            projector: TangentProjector::new(c, SolverSettings::default()),
            force: vec![0.0; n],
            next_r: vec![0.0; n],
            next_v: vec![0.0; n],
            dmu: vec![0.0; m],
            system,
        }
    }
}

impl<S: System> Scheme for ProjectedSymplecticEuler<S> {
    type System = S;

    fn system(&self) -> &S {
        &self.system
    }

    fn step(&mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64]) -> StepResult {
        let (c, mass) = (self.system.constraint(), self.system.mass());
        check_step_input(&self.system, r, v, h, dw)?;
        self.system.drift(r, v, &mut self.force);
        for f in self.force.iter_mut() {
            *f *= h;
        }
        self.system.add_noise(r, v, dw, &mut self.force);
        mass.apply_inverse(&mut self.force);
        for (((x, x0), v0), dv) in self
            .next_r
            .iter_mut()
            .zip(r.iter())
            .zip(v.iter())
            .zip(&self.force)
        {
            *x = x0 + h * (v0 + dv);
        }
        let certificate = self
            .projector
            .project_position(c, mass, &mut self.next_r)
            .map_err(|source| StepFailure::Root {
                what: "projection onto the manifold",
                source,
            })?;
        for ((w, x), x0) in self.next_v.iter_mut().zip(&self.next_r).zip(r.iter()) {
            *w = (x - x0) / h;
        }
        self.projector
            .project_velocity(c, mass, &self.next_r, &mut self.next_v)?;
        StepFailure::check_finite("velocity after the step", &self.next_v)?;
        r.copy_from_slice(&self.next_r);
        v.copy_from_slice(&self.next_v);
        Ok(StepOutcome {
            newton_iterations: certificate.iterations,
            ..StepOutcome::PLAIN
        })
    }

    fn multiplier_increment(&self) -> &[f64] {
        &self.dmu
    }
}

/// The study settings of both systems: 400 paths, h = 2^-3 .. 2^-7, reference 2^-12.
fn settings(scene: &Scene) -> ConvergenceSettings {
    ConvergenceSettings {
        paths: 400,
        coarsest: 3,
        finest: 7,
        reference: Some(12),
        schemes: vec![
            SchemeKind::HalfExplicitPractical,
            SchemeKind::ProjectedEulerMaruyama,
        ],
        ..ConvergenceSettings::for_scene(scene)
    }
}

/// Runs the study of `prepared` with the built-in schemes and the scheme of this example.
fn study<S>(scene: &Scene, prepared: &Prepared<S>) -> Result<ConvergenceReport, String>
where
    S: CurvedSystem + Clone + Send + Sync + 'static,
{
    let system = prepared.system.clone();
    let ours = StudyScheme::new("projected-symplectic-euler", move || {
        Ok(ProjectedSymplecticEuler::new(system.clone()))
    });
    let run = run_convergence_on(
        scene,
        prepared,
        &[ours],
        &settings(scene),
        (0, 1),
        Control::default(),
    )
    .map_err(|e| e.to_string())?;
    Ok(build_report(run))
}

/// A built-in scene's system type is known only inside a [`SceneRunner`].
struct Study;

impl SceneRunner for Study {
    type Output = Result<ConvergenceReport, String>;
    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> Self::Output
    where
        S: CurvedSystem + Clone + Send + Sync + 'static,
    {
        study(scene, &prepared)
    }
}

/// A particle of unit mass on the ellipse x^2/a^2 + y^2/b^2 = 1 (a = 2, b = 1), under gravity
/// -e_y and additive noise of amplitude 0.5: constraint, curvature and drift from closures.
fn ellipse_study() -> Result<ConvergenceReport, String> {
    const A2: f64 = 4.0;
    const B2: f64 = 1.0;
    let ellipse = ClosureConstraint::new(
        2,
        1,
        |x: &[f64], g: &mut [f64]| g[0] = 0.5 * (x[0] * x[0] / A2 + x[1] * x[1] / B2 - 1.0),
        |x: &[f64], u: &[f64], out: &mut [f64]| out[0] = x[0] * u[0] / A2 + x[1] * u[1] / B2,
        |x: &[f64], z: &[f64], out: &mut [f64]| {
            out[0] = x[0] * z[0] / A2;
            out[1] = x[1] * z[0] / B2;
        },
    )
    .map_err(|e| e.to_string())?
    .with_second_derivative(|_x: &[f64], u: &[f64], w: &[f64], out: &mut [f64]| {
        out[0] = u[0] * w[0] / A2 + u[1] * w[1] / B2;
    });
    let gravity = |_r: &[f64], _v: &[f64], out: &mut [f64]| {
        out[0] = 0.0;
        out[1] = -1.0;
    };
    let noise = AdditiveNoise::new(0.5, 2).map_err(|e| e.to_string())?;
    let system =
        MechanicalSystem::new(ellipse, IdentityMass, gravity, noise).map_err(|e| e.to_string())?;
    let scene = Scene::custom(
        "ellipse",
        2.0,
        vec![Output::Position, Output::Velocity],
        1.0,
    )
    .map_err(|e| e.to_string())?;
    // At the bottom of the ellipse, moving along it.
    let prepared = scene
        .prepare_custom(system, vec![0.0, -1.0], vec![0.8, 0.0])
        .map_err(|e| e.to_string())?;
    study(&scene, &prepared)
}

fn print(report: &ConvergenceReport, dir: &Path) -> Result<(), String> {
    println!("{} ({} paths):", report.scene, report.paths);
    for scheme in &report.schemes {
        let order = |fit| match fit {
            Some(fit) => describe_fit(fit),
            None => "-".into(),
        };
        println!(
            "  {:<28} order in r: {:<28} in v: {}",
            scheme.name,
            order(scheme.observed_order.r.as_ref()),
            order(scheme.observed_order.v.as_ref())
        );
    }
    let dir = dir.join(&report.scene);
    write_report(report, &dir).map_err(|e| e.to_string())?;
    println!("  report: {}", dir.join("report.json").display());
    Ok(())
}

fn main() -> Result<(), String> {
    let out = Path::new("target/custom-scheme");
    // The pendulum scene without the multiplier, which this example's scheme does not give.
    let pendulum = Scene {
        outputs: vec![Output::Position, Output::Velocity],
        ..Scene::built_in("pendulum").map_err(|e| e.to_string())?
    };
    let report = pendulum.run(Study).map_err(|e| e.to_string())??;
    print(&report, out)?;
    print(&ellipse_study()?, out)
}
