//! Bring your own scheme, and your own system, to a convergence study, and step it in SIMD
//! lanes.
//!
//! The scheme is defined here, written once over the number type ([`KernelScheme`]): a
//! symplectic Euler step (momentum first, then the position with the new velocity) whose
//! constraint is kept by the constrained update of the half-explicit scheme (a SHAKE-type
//! step). [`Kernelized`] runs it path by path and, in an ensemble, W paths at a time in SIMD
//! lanes. It runs side by side with the built-in schemes on
//!
//! - the seed's stochastic pendulum (a built-in scene: a sphere, the closed-form root in
//!   lanes), and
//! - a particle on an ellipse x^2/a^2 + y^2/b^2 = 1, defined here by its g and grad g over
//!   [`Real`] ([`Surface`]: Newton in lanes), under gravity and additive noise.
//!
//! Before each study it checks that every path of an ensemble in lanes, at W = 1, 4 and 8, is
//! the path-by-path run's bit for bit (r, v and mu after 200 steps), and that the lanes decided
//! every step; any difference ends the run with an error.
//!
//! Run with `cargo run --release -p sdae-study --example custom_scheme`; it prints the observed
//! strong orders of every scheme and writes the reports under `target/custom-scheme/`.

use std::path::Path;
use std::time::Instant;

use sdae_lanes::{LaneWidth, Real};
use sdae_manifold::{Hypersurface, IdentityMass, Surface};
use sdae_model::{
    AdditiveNoise, KernelNext, KernelOutcome, KernelScheme, KernelState, Kernelized, LaneEnsemble,
    MechanicalSystem, PathEnsemble, PathState, StepFailure, StepKernel, System,
};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_reference::CurvedSystem;
use sdae_study::convergence::{
    ConvergenceReport, ConvergenceSettings, build_report, run_convergence_on,
};
use sdae_study::integrator::{SchemeKind, StudyScheme};
use sdae_study::output::{describe_fit, write_report};
use sdae_study::parallel::Control;
use sdae_study::scene::{Output, Prepared, Scene, SceneRunner};

/// Symplectic Euler with the half-explicit constrained update, for
/// M dv = a dt + B dw + grad g dmu, g(r) = 0:
///
/// ```text
/// v~ = v + M^-1 [a(r, v) h + B(r, v) dw]
/// r' = r + h v~ + M^-1 grad g(r) kappa,   g(r') = 0
/// v' = v~ + M^-1 grad g(r) lambda,        Dg(r') v' = 0,   mu' = mu + lambda
/// ```
///
/// Written once over `T: Real`: one path in `f64`, W paths in lanes.
#[derive(Debug, Clone)]
struct ConstrainedSymplecticEuler<S> {
    system: S,
}

impl<S: System + Clone + Send + Sync + 'static> KernelScheme for ConstrainedSymplecticEuler<S> {
    type System = S;

    fn system(&self) -> &S {
        &self.system
    }

    #[inline(always)]
    fn step<T: Real, K: StepKernel<T>>(
        &self, kernel: &mut K, h: f64, state: KernelState<'_, T>, next: KernelNext<'_, T>,
    ) -> Result<KernelOutcome<T>, StepFailure> {
        let KernelState { r, v, dw } = state;
        let KernelNext {
            r: next_r,
            v: free_velocity,
            dmu,
            work: y,
        } = next;
        // v~ = v + M^-1 (h a + B dw) in the velocity's rows, y = r + h v~, then r' and v' (in
        // place of v~) by the constrained update.
        let h = kernel.splat(h);
        kernel.free_velocity(r, v, dw, h, free_velocity);
        for ((yi, ri), wi) in y.iter_mut().zip(r).zip(free_velocity.iter()) {
            *yi = *ri + h * *wi;
        }
        let constrained = kernel.constrain(r, y, free_velocity, next_r, dmu)?;
        Ok(KernelOutcome::untruncated(constrained))
    }
}

/// Paths and steps of the check that lanes and one path agree.
const CHECK_PATHS: usize = 37;
const CHECK_STEPS: usize = 200;
const CHECK_H: f64 = 0.01;
const CHECK_SEED: u64 = 5;

/// Every path's final (r, v, mu) as bits, path by path.
fn one_path_bits<S>(
    scheme: &ConstrainedSymplecticEuler<S>, r0: &[f64], v0: &[f64],
) -> Result<Vec<Vec<u64>>, String>
where
    S: System + Clone + Send + Sync + 'static,
{
    let mut kernelized = Kernelized::new(scheme.clone()).map_err(|e| e.to_string())?;
    let l = scheme.system.noise_dim();
    (0..CHECK_PATHS)
        .map(|p| {
            let mut noise = GaussianIncrements::for_path(CHECK_SEED, p as u64, l);
            let (mut r, mut v) = (r0.to_vec(), v0.to_vec());
            let mut path = PathState::new(1, true, false);
            let mut dw = vec![0.0; l];
            for _ in 0..CHECK_STEPS {
                noise.next_increment(CHECK_H, &mut dw);
                path.step(&mut kernelized, &mut r, &mut v, CHECK_H, &dw)
                    .map_err(|e| format!("path {p}: {e}"))?;
            }
            Ok(r.iter()
                .chain(&v)
                .chain(&path.mu)
                .map(|x| x.to_bits())
                .collect())
        })
        .collect()
}

/// Every path's final (r, v, mu) as bits in an ensemble of `width`, and the path-steps the
/// lanes left to the one-path step.
fn lane_bits<S>(
    scheme: &ConstrainedSymplecticEuler<S>, r0: &[f64], v0: &[f64], width: LaneWidth,
) -> Result<(Vec<Vec<u64>>, usize), String>
where
    S: System + Clone + Send + Sync + 'static,
{
    let kernelized = Kernelized::new(scheme.clone()).map_err(|e| e.to_string())?;
    let mut ensemble = LaneEnsemble::new(kernelized, CHECK_PATHS, r0, v0)
        .map_err(|e| e.to_string())?
        .with_width(width);
    let l = scheme.system.noise_dim();
    let mut sources: Vec<_> = (0..CHECK_PATHS)
        .map(|p| GaussianIncrements::for_path(CHECK_SEED, p as u64, l))
        .collect();
    let stride = ensemble.stride();
    let (mut dw, mut one) = (vec![0.0; l * stride], vec![0.0; l]);
    for _ in 0..CHECK_STEPS {
        for (p, source) in sources.iter_mut().enumerate() {
            source.next_increment(CHECK_H, &mut one);
            for j in 0..l {
                dw[j * stride + p] = one[j];
            }
        }
        ensemble.step(CHECK_H, &dw).map_err(|e| e.to_string())?;
    }
    let n = r0.len();
    let mut bits = Vec::with_capacity(CHECK_PATHS);
    for p in 0..CHECK_PATHS {
        let (mut r, mut v, mut mu) = (vec![0.0; n], vec![0.0; n], vec![0.0; 1]);
        ensemble
            .state(p, &mut r, &mut v, &mut mu)
            .map_err(|e| e.to_string())?;
        bits.push(r.iter().chain(&v).chain(&mu).map(|x| x.to_bits()).collect());
    }
    Ok((bits, ensemble.scalar_steps()))
}

/// Checks that the scheme's paths in lanes are its paths one at a time, bit for bit, at
/// W = 1, 4 and 8 (the machine's widest where narrower), with every step decided in lanes.
fn check_lanes<S>(name: &str, system: &S, r0: &[f64], v0: &[f64]) -> Result<(), String>
where
    S: System + Clone + Send + Sync + 'static,
{
    let scheme = ConstrainedSymplecticEuler {
        system: system.clone(),
    };
    let clock = Instant::now();
    let expected = one_path_bits(&scheme, r0, v0)?;
    let one_path_time = clock.elapsed().as_secs_f64() * 1e3;
    for width in [LaneWidth::One, LaneWidth::Four, LaneWidth::Eight] {
        let clock = Instant::now();
        let (bits, left) = lane_bits(&scheme, r0, v0, width)?;
        let lane_time = clock.elapsed().as_secs_f64() * 1e3;
        let differing = (0..CHECK_PATHS).filter(|&p| bits[p] != expected[p]).count();
        println!(
            "{name}, {width:?} (W = {} here): {differing} of {CHECK_PATHS} paths differ from one \
             path at a time, {left} steps left to it; {lane_time:.2} ms in lanes, \
             {one_path_time:.2} ms path by path",
            width.lanes()
        );
        if differing > 0 || left > 0 {
            return Err(format!(
                "{name} at W = {}: {differing} paths differ, {left} one-path steps",
                width.lanes()
            ));
        }
    }
    Ok(())
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

/// Checks the scheme in lanes, then runs the study of `prepared` with the built-in schemes and
/// the scheme of this example (its ensembles in lanes).
fn study<S>(scene: &Scene, prepared: &Prepared<S>) -> Result<ConvergenceReport, String>
where
    S: CurvedSystem + Clone + Send + Sync + 'static,
{
    let system = prepared.system.clone();
    check_lanes(&scene.name, &system, &prepared.position, &prepared.velocity)?;
    let ours = StudyScheme::in_lanes("constrained-symplectic-euler", move || {
        Ok(ConstrainedSymplecticEuler {
            system: system.clone(),
        })
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

/// The ellipse x^2/a^2 + y^2/b^2 = 1 (a = 2, b = 1) as g = (x^2/a^2 + y^2/b^2 - 1) / 2.
#[derive(Debug, Clone, Copy)]
struct Ellipse;

const A2: f64 = 4.0;
const B2: f64 = 1.0;

impl Surface<2> for Ellipse {
    #[inline(always)]
    fn value<T: Real>(&self, x: &[T; 2]) -> T {
        (x[0] * x[0] / A2 + x[1] * x[1] / B2 - 1.0) * 0.5
    }
    #[inline(always)]
    fn gradient<T: Real>(&self, x: &[T; 2]) -> [T; 2] {
        [x[0] / A2, x[1] / B2]
    }
    #[inline(always)]
    fn second_derivative<T: Real>(&self, _x: &[T; 2], u: &[T; 2], w: &[T; 2]) -> T {
        u[0] * w[0] / A2 + u[1] * w[1] / B2
    }
}

/// A particle of unit mass on the ellipse, under gravity -e_y and additive noise of amplitude
/// 0.5.
fn ellipse_study() -> Result<ConvergenceReport, String> {
    let gravity = |_r: &[f64], _v: &[f64], out: &mut [f64]| {
        out[0] = 0.0;
        out[1] = -1.0;
    };
    let noise = AdditiveNoise::new(0.5, 2).map_err(|e| e.to_string())?;
    let system = MechanicalSystem::new(Hypersurface::new(Ellipse), IdentityMass, gravity, noise)
        .map_err(|e| e.to_string())?;
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
