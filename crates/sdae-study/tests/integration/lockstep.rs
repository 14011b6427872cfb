//! The lockstep driver against a direct computation: the same scheme run level by level with
//! the whole Brownian path in memory (sdae_model::run_path, Recorder, Coarsened), on a fine
//! grid longer than one chunk so that coarse steps span several chunks, and with the reference
//! so far above the finest level that a chunk is shorter than one finest step; a path gives
//! the same numbers whatever block of paths it runs in.

use sdae_manifold::Mass;
use sdae_model::{Recorder, Scheme, System, TimeGrid, run_path};
use sdae_noise::{Coarsened, GaussianIncrements, IncrementSource, RecordedIncrements};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_study::integrator::{SchemeConstants, SchemeKind, build_ensemble};
use sdae_study::lockstep::{BlockEnsembles, Limits, PathPlan, run_block};
use sdae_systems::{PendulumParams, pendulum};

/// The schemes' constants with the practical C_eta `practical_c_eta` and no ball on kappa.
fn constants(practical_c_eta: f64) -> SchemeConstants {
    SchemeConstants {
        theory: None,
        practical_c_eta,
        c_kappa: f64::INFINITY,
        local_c_eta: 0.5,
        geodesic_substeps: 3,
        projection_tolerance: 1e-12,
    }
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

#[test]
fn lockstep_matches_a_direct_run_of_each_level() {
    matches_a_direct_run(14, &[1, 4, 9]);
}

#[test]
fn a_reference_far_above_the_finest_level_gives_the_same_distances() {
    // A finest step of 2^13 fine steps, longer than a chunk (2^12).
    matches_a_direct_run(16, &[1, 2, 3]);
}

fn matches_a_direct_run(fine: u32, levels: &[u32]) {
    let system = pendulum(PendulumParams::default()).unwrap();
    let constants = constants(1.0);
    let (r0, v0) = (vec![0.0, -1.0], vec![1.0, 0.0]);
    let plan = PathPlan {
        t_end: 1.0,
        fine,
        levels: levels.to_vec(),
        want_mu: true,
        limits: Limits::default(),
        kinetic_after: None,
        time_averaged: None,
        observing: None,
        paired_reference: false,
    };
    let ensembles = |paths: usize| {
        let build = |kind| build_ensemble(kind, &system, &constants, paths, &r0, &v0).unwrap();
        BlockEnsembles {
            tracks: levels
                .iter()
                .map(|_| build(SchemeKind::HalfExplicitPractical))
                .collect(),
            own_clock: vec![false; levels.len()],
            reference: Some(build(SchemeKind::HalfExplicitPractical)),
            coarse_reference: None,
        }
    };
    let (seed, index) = (11, 3);
    // Path 3 in a block with others, and alone in a wider one: the same numbers.
    let run = |paths: usize, indices: &[usize]| {
        run_block(&plan, &mut ensembles(paths), (&r0, &v0), seed, indices).unwrap()
    };
    let record = run(3, &[5, 3, 8]).swap_remove(1);
    let alone = run(16, &[3]).swap_remove(0);
    assert_eq!(record.index, index);
    for (a, b) in record.tracks.iter().zip(&alone.tracks) {
        assert_eq!((a.distances, a.steps), (b.distances, b.steps));
    }
    assert!(record.reference_failure.is_none());
    let (r0, v0) = (&r0[..], &v0[..]);
    let direct = direct_distances(system, r0, v0, seed, index, fine, levels);
    for (j, (&level, sup)) in levels.iter().zip(direct).enumerate() {
        let lockstep = record.tracks[j].distances.unwrap();
        assert_eq!(record.tracks[j].steps, 1usize << level);
        for c in 0..3 {
            // Pairwise and sequential sums of the increments differ by rounding only.
            assert!(
                (lockstep[c] - sup[c]).abs() <= 1e-9 * sup[c].max(1e-3),
                "level {level}, component {c}: lockstep {} direct {}",
                lockstep[c],
                sup[c]
            );
        }
        assert!(sup[0] > 0.0);
    }
}

/// The largest distances of r, v and mu between each level and the reference on the finest
/// level's grid, computed directly: all 2^fine increments of path `index` in memory, each
/// level run on their sums.
fn direct_distances<S: System>(
    system: S, r0: &[f64], v0: &[f64], seed: u64, index: usize, fine: u32, levels: &[u32],
) -> Vec<[f64; 3]> {
    let fine_steps = 1usize << fine;
    let mut increments = vec![0.0; 2 * fine_steps];
    let mut noise = GaussianIncrements::for_path(seed, index as u64, 2);
    for dw in increments.chunks_exact_mut(2) {
        noise.next_increment(1.0 / fine_steps as f64, dw);
    }
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let finest = *levels.last().unwrap();
    let mut reference_path = Recorder::every(1 << (fine - finest)).with_mu();
    let (mut r, mut v) = (r0.to_vec(), v0.to_vec());
    let grid = TimeGrid::new(1.0, fine_steps).unwrap();
    let mut source = RecordedIncrements::new(&increments, 2);
    run_path(
        &mut stepper,
        &mut r,
        &mut v,
        grid,
        &mut source,
        &mut reference_path,
    )
    .unwrap();

    levels
        .iter()
        .map(|&level| {
            let steps = 1usize << level;
            let mut coarse = Recorder::every(1).with_mu();
            let mut source =
                Coarsened::new(RecordedIncrements::new(&increments, 2), fine_steps / steps);
            let (mut r, mut v) = (r0.to_vec(), v0.to_vec());
            let grid = TimeGrid::new(1.0, steps).unwrap();
            run_path(&mut stepper, &mut r, &mut v, grid, &mut source, &mut coarse).unwrap();
            let stride = 1 << (finest - level);
            let mut sup = [0.0_f64; 3];
            for k in 0..=steps {
                let d = [
                    distance(coarse.position(k), reference_path.position(k * stride)),
                    distance(coarse.velocity(k), reference_path.velocity(k * stride)),
                    distance(coarse.multiplier(k), reference_path.multiplier(k * stride)),
                ];
                for (s, x) in sup.iter_mut().zip(d) {
                    *s = s.max(x);
                }
            }
            sup
        })
        .collect()
}

/// The kinetic energy's time average of a time-changed scheme runs over its own clock: with
/// weights eta_k h, from the step whose own time sum_i eta_i h reaches the burn-in; on the
/// grid's clock it is the plain mean over the grid points from k h >= burn-in.
#[test]
fn a_time_changed_scheme_averages_over_its_own_clock() {
    let system = pendulum(PendulumParams::default()).unwrap();
    let constants = constants(0.05);
    let (r0, v0) = (vec![0.0, -1.0], vec![1.5, 0.0]);
    let (level, after, seed, index) = (4, 0.25, 5, 2);
    let plan = PathPlan {
        t_end: 1.0,
        fine: level,
        levels: vec![level],
        want_mu: false,
        limits: Limits::default(),
        kinetic_after: Some(after),
        time_averaged: None,
        observing: None,
        paired_reference: false,
    };
    let build = |own_clock: bool| {
        let build = |kind| build_ensemble(kind, &system, &constants, 4, &r0, &v0);
        BlockEnsembles {
            tracks: vec![build(SchemeKind::HalfExplicitRescaled).unwrap()],
            own_clock: vec![own_clock],
            reference: None,
            coarse_reference: None,
        }
    };
    let run = |own_clock| {
        let mut ensembles = build(own_clock);
        let record = run_block(&plan, &mut ensembles, (&r0, &v0), seed, &[index]).unwrap();
        record[0].tracks[0].clone()
    };
    let (own, grid) = (run(true), run(false));

    // Directly: the same increments through the scalar rescaled stepper.
    let steps = 1usize << level;
    let h = 1.0 / steps as f64;
    let config = StepperConfig::new(0.05, f64::INFINITY).unwrap().rescaled();
    let mut stepper = Stepper::new(system.clone(), config).unwrap();
    let mut noise = GaussianIncrements::for_path(seed, index as u64, 2);
    let (mut r, mut v) = (r0.clone(), v0.clone());
    let (mut dw, mut mv) = (vec![0.0; 2], vec![0.0; 2]);
    let (mut time, mut weighted, mut weights) = (0.0, 0.0, 0.0);
    let (mut sum, mut count, mut truncated) = (0.0, 0.0, 0);
    for k in 1..=steps {
        noise.next_increment(h, &mut dw);
        let outcome = stepper.step(&mut r, &mut v, h, &dw).unwrap();
        truncated += usize::from(outcome.eta < 1.0);
        system.mass().apply(&v, &mut mv);
        let energy = 0.5 * (v[0] * mv[0] + v[1] * mv[1]);
        time += outcome.eta * h;
        if time >= after * (1.0 - 1e-12) {
            weighted += outcome.eta * h * energy;
            weights += outcome.eta * h;
        }
        if k as f64 * h >= after * (1.0 - 1e-12) {
            sum += energy;
            count += 1.0;
        }
    }
    assert!(truncated > steps / 4, "the test needs truncated steps");
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    let (own, grid) = (own.kinetic_energy.unwrap(), grid.kinetic_energy.unwrap());
    assert!(
        close(own, weighted / weights),
        "{own} against {}",
        weighted / weights
    );
    assert!(close(grid, sum / count), "{grid} against {}", sum / count);
    assert!(!close(own, grid), "the clocks should differ here");
}

/// The paired reference runs at half the reference's steps on pairwise sums of its increments:
/// its observed values are exactly those of the same scheme run as a track at that level, and
/// the reference's own values are those of the run without the pair (fine grid longer than one
/// chunk, so that the pair's steps and observations cross chunks).
#[test]
fn the_paired_reference_is_the_scheme_at_half_the_steps() {
    use sdae_study::lockstep::Observing;
    use sdae_study::observable::Observable;
    let system = pendulum(PendulumParams::default()).unwrap();
    let constants = constants(1.0);
    let (r0, v0) = (vec![0.0, -1.0], vec![1.0, 0.0]);
    let fine = 14;
    let height = Observable::new("height", |r: &[f64], _: &[f64]| r[1]);
    let speed = Observable::new("speed", |_: &[f64], v: &[f64]| v[0].hypot(v[1]));
    let plan = |paired_reference| PathPlan {
        t_end: 1.0,
        fine,
        levels: vec![2, fine - 1],
        want_mu: false,
        limits: Limits::default(),
        kinetic_after: None,
        time_averaged: None,
        observing: Some(Observing {
            observables: vec![height.clone(), speed.clone()],
            grid_level: 2,
        }),
        paired_reference,
    };
    let kind = SchemeKind::BaoabRattle;
    let build = || build_ensemble(kind, &system, &constants, 4, &r0, &v0).unwrap();
    let mut paired = BlockEnsembles {
        tracks: vec![build(), build()],
        own_clock: vec![false; 2],
        reference: Some(build()),
        coarse_reference: Some(build()),
    };
    let mut alone = BlockEnsembles {
        tracks: vec![build(), build()],
        own_clock: vec![false; 2],
        reference: Some(build()),
        coarse_reference: None,
    };
    let indices = [0, 7, 3];
    let with = run_block(&plan(true), &mut paired, (&r0, &v0), 5, &indices).unwrap();
    let without = run_block(&plan(false), &mut alone, (&r0, &v0), 5, &indices).unwrap();
    for (a, b) in with.iter().zip(&without) {
        assert!(a.reference_failure.is_none());
        assert_eq!(a.reference_coarse_observed.len(), 2 * 4);
        assert_eq!(a.reference_coarse_observed, a.tracks[1].observed);
        assert_eq!(a.reference_observed, b.reference_observed);
        assert!(b.reference_coarse_observed.is_empty());
        assert_ne!(a.reference_observed, a.reference_coarse_observed);
    }
}
