//! Monte Carlo over paths on a thread pool: which schemes apply to a scene, and the records of
//! the selected paths, each from its own random stream (the numbers do not depend on the thread
//! count or the sharding).

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;
use sdae_reference::CurvedSystem;
use serde::{Deserialize, Serialize};

use crate::integrator::{Integrator, SchemeKind, build_integrator};
use crate::lockstep::{PathPlan, PathRecord, run_path};
use crate::scene::Prepared;

/// A scheme left out, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Skipped {
    /// The scheme.
    pub name: String,
    /// Why it does not apply.
    pub reason: String,
}

/// The schemes of `kinds` that apply to the scene (each built once to find out), and the rest
/// with the reason.
pub fn applicable<S>(
    kinds: &[SchemeKind],
    prepared: &Prepared<S>,
) -> (Vec<SchemeKind>, Vec<Skipped>)
where
    S: CurvedSystem + Clone + 'static,
{
    let mut run = Vec::new();
    let mut skipped = Vec::new();
    for &kind in kinds {
        let reason = if kind == SchemeKind::StochasticHeun
            && !prepared.noise_independent_of_velocity
        {
            Some(
                "the noise depends on v: stochastic Heun would converge to the Stratonovich solution"
                    .to_string(),
            )
        } else {
            build_integrator(kind, &prepared.system, &prepared.constants).err()
        };
        match reason {
            None => run.push(kind),
            Some(reason) => skipped.push(Skipped {
                name: kind.name().into(),
                reason,
            }),
        }
    }
    (run, skipped)
}

/// Builds the integrators of `kinds` (all known to apply).
fn integrators<S>(kinds: &[SchemeKind], prepared: &Prepared<S>) -> Vec<Box<dyn Integrator>>
where
    S: CurvedSystem + Clone + 'static,
{
    kinds
        .iter()
        .map(|&k| {
            build_integrator(k, &prepared.system, &prepared.constants)
                .expect("checked by `applicable`")
        })
        .collect()
}

/// Which paths to run, and on how many threads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSelection {
    /// Seed of the path streams.
    pub seed: u64,
    /// All paths of the study.
    pub paths: usize,
    /// Run the paths i with i % shard.1 == shard.0.
    pub shard: (usize, usize),
    /// Worker threads.
    pub threads: usize,
}

/// Runs the selected paths of `plan` with `schemes` (and `reference`, if given; all must
/// apply), sorted by index; `progress` is called with the number of finished paths.
pub fn run_paths<S>(
    plan: &PathPlan,
    schemes: &[SchemeKind],
    reference: Option<SchemeKind>,
    prepared: &Prepared<S>,
    selection: PathSelection,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<PathRecord>, String>
where
    S: CurvedSystem + Clone + Sync + 'static,
{
    let (index, count) = selection.shard;
    let mine: Vec<usize> = (0..selection.paths)
        .filter(|i| i % count.max(1) == index)
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(selection.threads.max(1))
        .build()
        .map_err(|e| format!("cannot start {} threads: {e}", selection.threads))?;
    let done = AtomicUsize::new(0);
    let reference: Vec<SchemeKind> = reference.into_iter().collect();
    let records = pool.install(|| {
        mine.par_iter()
            .map_init(
                || {
                    let reference = integrators(&reference, prepared).pop();
                    (integrators(schemes, prepared), reference)
                },
                |(tracks, reference), &i| {
                    let record = run_path(
                        plan,
                        tracks,
                        reference.as_mut(),
                        (&prepared.position, &prepared.velocity),
                        selection.seed,
                        i,
                    );
                    progress(done.fetch_add(1, Ordering::Relaxed) + 1);
                    record
                },
            )
            .collect::<Vec<_>>()
    });
    Ok(records)
}
