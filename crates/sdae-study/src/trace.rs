//! A picture of a scene: one path of the half-explicit scheme (practical C_eta) at the scene's
//! finest study step, recorded at a few hundred times, written as CSV and drawn as SVG. A
//! single particle (the pendulum) is drawn as its path; several particles (a molecule, a fiber)
//! as their shape at a few times, projected on the (x, z) plane in R^3.

use std::fmt::Write as _;
use std::path::Path;

use sdae_model::{Recorder, TimeGrid, run_path};
use sdae_noise::GaussianIncrements;
use sdae_reference::CurvedSystem;
use sdae_scheme::{Stepper, StepperConfig};

use crate::error::StudyError;
use crate::plots::figure::{Axis, Figure, Panel, Point, Series, render};
use crate::scene::{Prepared, Scene, SceneRunner};

/// Shapes drawn for a scene of several particles.
const SHAPES: usize = 6;
/// Particles of a shape drawn with a marker each, at most.
const MARKED: usize = 40;
/// Recorded states of a path, at most.
const RECORDS: usize = 400;
/// Recorded coordinates of a path, at most (a 10^4-bead fiber gets fewer states).
const COORDINATES: usize = 1 << 21;

/// The finest level a trace takes: 2^24 steps.
pub const MAX_LEVEL: u32 = 24;

/// The number of steps of a scene's trace, 2^k with k its finest study level (of `[study]`,
/// else `[stability]`, else `[equipartition]`; default 10); refused above [`MAX_LEVEL`], naming
/// the scene-file key.
pub fn steps(scene: &Scene) -> Result<usize, StudyError> {
    let (key, finest) = [
        ("study.levels", scene.study.levels),
        (
            "stability.levels",
            scene.stability.as_ref().map(|s| s.levels),
        ),
        (
            "equipartition.levels",
            scene.equipartition.as_ref().map(|e| e.levels),
        ),
    ]
    .into_iter()
    .find_map(|(key, levels)| levels.map(|l| (key, l[1])))
    .unwrap_or(("", 10));
    if finest > MAX_LEVEL {
        return Err(StudyError::Invalid {
            scene: scene.name.clone(),
            message: format!(
                "{key} ends at {finest}: a trace takes at most 2^{MAX_LEVEL} steps (level \
                 {MAX_LEVEL})"
            ),
        });
    }
    Ok(1 << finest)
}

/// One recorded path of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Space dimension of a particle (2 or 3).
    pub particle_dim: usize,
    /// (t, r) at the recorded times.
    pub states: Vec<(f64, Vec<f64>)>,
    /// Why the path stopped early, if it did.
    pub failure: Option<String>,
}

/// Records one path (stream `seed`, path 0) of `scene` with `steps` steps.
pub fn trace(scene: &Scene, steps: usize, seed: u64) -> Result<Trace, StudyError> {
    scene.run(Tracer { steps, seed })
}

struct Tracer {
    steps: usize,
    seed: u64,
}

impl SceneRunner for Tracer {
    type Output = Trace;
    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> Trace
    where
        S: CurvedSystem + Clone + Send + Sync + 'static,
    {
        let n = prepared.position.len();
        let particle_dim = if n.is_multiple_of(3) { 3 } else { 2 };
        let l = prepared.system.noise_dim();
        let mut noise = GaussianIncrements::for_path(self.seed, 0, l);
        let config = StepperConfig::new(
            prepared.constants.practical_c_eta,
            prepared.constants.c_kappa,
        );
        let grid = TimeGrid::new(scene.t_end, self.steps.max(1));
        let (config, grid) = match (config, grid) {
            (Ok(c), Ok(g)) => (c, g),
            (Err(e), _) => return failed(particle_dim, e.to_string()),
            (_, Err(e)) => return failed(particle_dim, e.to_string()),
        };
        let mut stepper = match Stepper::new(prepared.system, config) {
            Ok(s) => s,
            Err(e) => return failed(particle_dim, e.to_string()),
        };
        let (mut r, mut v) = (prepared.position, prepared.velocity);
        let records = RECORDS.min(COORDINATES / n.max(1)).max(2);
        let mut recorder = Recorder::every((self.steps / records).max(1));
        let outcome = run_path(
            &mut stepper,
            &mut r,
            &mut v,
            grid,
            &mut noise,
            &mut recorder,
        );
        let states = (0..recorder.len())
            .map(|i| (recorder.times[i], recorder.position(i).to_vec()))
            .collect();
        Trace {
            particle_dim,
            states,
            failure: outcome.err().map(|e| e.to_string()),
        }
    }
}

fn failed(particle_dim: usize, message: String) -> Trace {
    Trace {
        particle_dim,
        states: Vec::new(),
        failure: Some(message),
    }
}

/// The trace as CSV: t, then the coordinates of r.
pub fn csv(trace: &Trace) -> String {
    let n = trace.states.first().map_or(0, |s| s.1.len());
    let mut s = String::from("t");
    for i in 0..n {
        let _ = write!(s, ",r{i}");
    }
    s += "\n";
    for (t, r) in &trace.states {
        let _ = write!(s, "{t:e}");
        for x in r {
            let _ = write!(s, ",{x:e}");
        }
        s += "\n";
    }
    s
}

/// The (horizontal, vertical) coordinates drawn for particle `i` of r: (x, y) in the plane,
/// (x, z) in space.
fn point(r: &[f64], dim: usize, i: usize) -> (f64, f64) {
    let p = &r[dim * i..dim * (i + 1)];
    (p[0], p[dim - 1])
}

/// Draws the trace: the path of a single particle, or the shapes of several at a few times
/// (with a marker on each particle when there are at most 40).
pub fn plot(trace: &Trace, title: &str, path: &Path) -> Result<(), StudyError> {
    let dim = trace.particle_dim;
    let particles = trace.states.first().map_or(0, |s| s.1.len() / dim);
    let all: Vec<(f64, f64)> = trace
        .states
        .iter()
        .flat_map(|(_, r)| (0..particles).map(move |i| point(r, dim, i)))
        .collect();
    let (x0, x1, y0, y1) = all.iter().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), (x, y)| (a.min(*x), b.max(*x), c.min(*y), d.max(*y)),
    );
    if !(x0.is_finite() && y0.is_finite()) {
        return Err(StudyError::write(path, "no finite state to draw"));
    }
    // Equal scales on both axes, with a margin.
    let half = 0.55 * (x1 - x0).max(y1 - y0).max(1e-9);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let series = if particles == 1 {
        let points = all.iter().map(|&(x, y)| Point::at(x, y)).collect();
        vec![Series {
            no_markers: true,
            thin: true,
            ..Series::new("", points)
        }]
    } else {
        let count = trace.states.len();
        (0..SHAPES)
            .filter_map(|k| trace.states.get(k * (count - 1) / (SHAPES - 1).max(1)))
            .map(|(t, r)| {
                let points = (0..particles).map(|i| {
                    let (x, y) = point(r, dim, i);
                    Point::at(x, y)
                });
                Series {
                    no_markers: particles > MARKED,
                    ..Series::new(format!("t = {t:.3}"), points.collect())
                }
            })
            .collect()
    };
    let panel = Panel {
        title: String::new(),
        x: Axis::linear("x").within(cx - half..cx + half),
        y: Axis::linear(if dim == 3 { "z" } else { "y" }).within(cy - half..cy + half),
        series,
        guides: Vec::new(),
    };
    let mut figure = Figure::row(title, vec![panel]);
    figure.panel_size = (540, 520);
    render(&figure, path).map(|_| ())
}
