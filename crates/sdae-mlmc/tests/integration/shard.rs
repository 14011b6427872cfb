//! A plan run in shards and merged gives the unsharded sums bit for bit (the time aside), whatever the shard
//! count and the order the shards come in; shards of another run, missing or repeated shards
//! and blocks that are not whole are refused.

use crate::linear::Linear;

use sdae_mlmc::algorithm::{Plan, run_plan};
use sdae_mlmc::shard::{MlmcShard, merge, run_shard};
use sdae_mlmc::{LevelSums, MlmcError, RunControl};

/// The sums without the time they took.
fn untimed(mut sums: Vec<LevelSums>) -> Vec<LevelSums> {
    for s in &mut sums {
        s.seconds = 0.0;
    }
    sums
}

/// N_l of a plan with a level whose last block is partial (BLOCK = 32).
fn plan() -> Plan {
    Plan {
        eps: 1e-2,
        samples: vec![200, 70, 33],
    }
}

fn shards(model: &Linear, count: u64, identity: &str) -> Vec<MlmcShard<String>> {
    let control = RunControl::new(2).unwrap();
    (0..count)
        .map(|i| run_shard(model, &control, identity.to_string(), plan(), (i, count)).unwrap())
        .collect()
}

fn refused(shards: &[MlmcShard<String>], words: &str) {
    match merge(shards) {
        Err(MlmcError::Merge { reason }) => assert!(reason.contains(words), "{reason}"),
        other => panic!("not refused ({words}): {other:?}"),
    }
}

#[test]
fn merged_shards_give_the_unsharded_sums() {
    let model = Linear::ou(7);
    let whole = run_plan(&model, &RunControl::new(1).unwrap(), &plan().samples).unwrap();
    for count in [1, 2, 3, 5] {
        let mut parts = shards(&model, count, "ou");
        parts.reverse();
        let (identity, merged_plan, sums) = merge(&parts).unwrap();
        assert_eq!(identity, "ou");
        assert_eq!(merged_plan, plan());
        assert_eq!(untimed(sums), untimed(whole.clone()), "{count} shards");
    }
}

#[test]
fn shards_that_do_not_make_one_run_are_refused() {
    let model = Linear::ou(7);
    let parts = shards(&model, 3, "ou");
    refused(&parts[..2], "shard 2/3 is missing");
    refused(
        &[parts[0].clone(), parts[0].clone(), parts[2].clone()],
        "repeated",
    );
    let mut other = parts.clone();
    other[1] = shards(&model, 3, "another")[1].clone();
    refused(&other, "belongs to another run");
    let mut torn = parts.clone();
    torn[0].levels[1].pop();
    refused(&torn, "level 1");
    refused(&[], "no shard files");
    let control = RunControl::new(1).unwrap();
    let bad = run_shard(&model, &control, "ou".to_string(), plan(), (3, 3));
    assert!(
        matches!(bad, Err(MlmcError::Setting { key: "shard", .. })),
        "{bad:?}"
    );
}
