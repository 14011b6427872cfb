//! Sharded runs merged give exactly the unsharded report (timings aside), and incomplete or
//! inconsistent shard sets are refused.

use sdae_study::{PendulumStudy, Shard, merge_shards, pendulum_study, run_paths};

fn study() -> PendulumStudy {
    PendulumStudy {
        paths: 40,
        coarsest: 2,
        finest: 4,
        reference: 8,
        threads: 2,
        ..PendulumStudy::default()
    }
}

fn shard(study: &PendulumStudy, index: usize, count: usize) -> Shard {
    // A shard file goes through JSON: check that the round trip is exact too.
    let shard = Shard {
        settings: PendulumStudy {
            threads: 1 + index,
            ..*study
        },
        index,
        count,
        records: run_paths(study, index, count, |_| {}),
    };
    serde_json::from_str(&serde_json::to_string(&shard).unwrap()).unwrap()
}

#[test]
fn merged_shards_reproduce_the_unsharded_report() {
    let s = study();
    let whole = pendulum_study(s, |_| {});
    let merged = merge_shards((0..3).map(|i| shard(&s, i, 3)).collect()).unwrap();
    assert_eq!(whole.levels.len(), merged.levels.len());
    for (a, b) in whole.levels.iter().zip(&merged.levels) {
        assert_eq!(a.error, b.error);
        assert_eq!(
            (
                a.truncated_fraction,
                a.newton_iterations_per_step,
                a.failures
            ),
            (
                b.truncated_fraction,
                b.newton_iterations_per_step,
                b.failures
            )
        );
    }
    assert_eq!(whole.observed_order, merged.observed_order);
}

#[test]
fn incomplete_or_inconsistent_shards_are_refused() {
    let s = study();
    let err = merge_shards(vec![shard(&s, 0, 3), shard(&s, 2, 3)]).unwrap_err();
    assert!(err.contains("missing"), "{err}");
    let err = merge_shards(vec![shard(&s, 0, 2), shard(&s, 0, 2), shard(&s, 1, 2)]).unwrap_err();
    assert!(err.contains("twice"), "{err}");
    let other = PendulumStudy { seed: 7, ..s };
    let err = merge_shards(vec![shard(&s, 0, 2), shard(&other, 1, 2)]).unwrap_err();
    assert!(err.contains("other settings"), "{err}");
    assert!(merge_shards(Vec::new()).is_err());
}
