//! Sharded runs merged give exactly the unsharded report (timings aside), the thread count does
//! not change the numbers, and incomplete or inconsistent shard sets are refused.

use crate::common;

use sdae_study::convergence::{ConvergenceReport, ConvergenceRun, build_report, merge_shards};

/// The report without its timings (which differ from run to run).
fn numbers(report: &ConvergenceReport) -> String {
    let mut report = report.clone();
    if let Some(r) = report.reference.as_mut() {
        r.seconds_per_path = 0.0;
    }
    for scheme in &mut report.schemes {
        for level in &mut scheme.levels {
            level.seconds_per_path = 0.0;
            level.seconds = Default::default();
            level.steps_per_second = 0.0;
        }
    }
    report.settings.threads = 0;
    serde_json::to_string(&report).unwrap()
}

fn shard(index: usize, count: usize, threads: usize) -> ConvergenceRun {
    let (scene, mut settings) = common::small(40);
    settings.threads = threads;
    let run = common::run(&scene, &settings, index, count);
    // A shard file goes through JSON: the round trip must be exact too.
    serde_json::from_str(&serde_json::to_string(&run).unwrap()).unwrap()
}

#[test]
fn merged_shards_reproduce_the_unsharded_report() {
    let whole = build_report(shard(0, 1, 2));
    let merged = merge_shards((0..3).map(|i| shard(i, 3, 1 + i % 2)).collect()).unwrap();
    assert_eq!(numbers(&whole), numbers(&merged));
    assert_eq!(whole.schemes.len(), 11);
    assert!(whole.schemes.iter().all(|s| {
        s.levels
            .iter()
            .all(|l| l.failures == 0 && l.error.r.is_some_and(|e| e.estimate > 0.0))
    }));
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let one = build_report(shard(0, 1, 1));
    let two = build_report(shard(0, 1, 2));
    assert_eq!(numbers(&one), numbers(&two));
}

#[test]
fn incomplete_or_inconsistent_shards_are_refused() {
    let err = merge_shards(vec![shard(0, 3, 1), shard(2, 3, 1)]).unwrap_err();
    assert!(err.to_string().contains("missing"), "{err}");
    let err = merge_shards(vec![shard(0, 2, 1), shard(0, 2, 1), shard(1, 2, 1)]).unwrap_err();
    assert!(err.to_string().contains("twice"), "{err}");
    let mut other = shard(1, 2, 1);
    other.settings.seed = 7;
    let err = merge_shards(vec![shard(0, 2, 1), other]).unwrap_err();
    assert!(err.to_string().contains("other settings"), "{err}");
    assert!(matches!(
        merge_shards(Vec::new()),
        Err(sdae_study::StudyError::Merge { .. })
    ));
}

#[test]
fn shards_holding_non_finite_numbers_are_written_read_and_merged() {
    let dir = std::env::temp_dir().join(format!("sdae-nonfinite-{}", std::process::id()));
    let mut first = shard(0, 2, 1);
    let track = &mut first.records[0].tracks[0];
    track.max_position_residual = f64::INFINITY;
    track.max_velocity_residual = f64::NAN;
    track.kinetic_energy = Some(f64::NEG_INFINITY);
    first.settings.limits.blow_up = f64::INFINITY;
    let second = {
        let mut s = shard(1, 2, 1);
        s.settings.limits.blow_up = f64::INFINITY;
        s
    };
    let mut read = Vec::new();
    for (i, run) in [first.clone(), second].iter().enumerate() {
        let file = dir.join(format!("shard-{i}-of-2.json"));
        sdae_study::files::write_json(&file, run).unwrap();
        let text = std::fs::read_to_string(&file).unwrap();
        assert!(text.contains("\"blow_up\": \"inf\""), "{text}");
        read.push(sdae_study::files::read_json::<ConvergenceRun>(&file).unwrap());
    }
    let back = &read[0].records[0].tracks[0];
    assert_eq!(back.max_position_residual, f64::INFINITY);
    assert!(back.max_velocity_residual.is_nan());
    assert_eq!(back.kinetic_energy, Some(f64::NEG_INFINITY));
    assert_eq!(read[0].settings.limits.blow_up, f64::INFINITY);
    let report = merge_shards(read).unwrap();
    let json = serde_json::to_string(&report).unwrap();
    assert!(json.contains("\"max_position_residual\":\"inf\""), "{json}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn merged_weak_shards_reproduce_the_unsharded_weak_report() {
    use sdae_cli::compare::numbers_of;
    use sdae_study::convergence::merge_runs;
    use sdae_study::scene::Scene;
    use sdae_study::weak::{build_weak_report, weak_settings};

    let scene = Scene::built_in("pendulum").unwrap();
    let mut settings = weak_settings(&scene, true).unwrap();
    settings.paths = 48;
    let run = |index: usize, count: usize| -> ConvergenceRun {
        let run = common::run(&scene, &settings, index, count);
        serde_json::from_str(&serde_json::to_string(&run).unwrap()).unwrap()
    };
    let report = |run: ConvergenceRun| {
        let report = build_weak_report(run).unwrap();
        numbers_of(&serde_json::to_string(&report).unwrap()).unwrap()
    };
    let whole = report(run(0, 1));
    let merged = report(merge_runs((0..3).map(|i| run(i, 3)).collect()).unwrap());
    assert_eq!(whole, merged);
    // The weak report holds every observable the scene names, with values on every level.
    let observables = whole["observables"].as_array().unwrap();
    assert_eq!(
        observables.len(),
        scene.weak.as_ref().unwrap().observables.len()
    );
    // Two of three shards are not the whole study.
    assert!(merge_runs((0..2).map(|i| run(i, 3)).collect()).is_err());
}
