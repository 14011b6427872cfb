//! The level sampler of a scene: a study scheme on both paths of each pair, [`BLOCK`] pairs
//! at a time in ensembles (SIMD lanes where the scheme and the system have a lane form).
//!
//! Sample i of level l draws the fine increments of path (seed, l 2^48 + i) two steps at a
//! time: the fine path takes them in order, the coarse path one step of 2 h with their sum (as
//! the lockstep driver sums a level's increments), and the antithetic twin the two in swapped
//! order. Its fine value is f at the fine path's end, or with the antithetic option the mean
//! of f over the fine path and its twin.

use std::ops::Range;

use sdae_lanes::LineVec;
use sdae_model::PathEnsemble;
use sdae_noise::{EnsembleIncrements, EnsembleNoise, MAX_SOBOL_DIMS, QuasiBrownian};

use crate::integrator::{BoxedEnsemble, StudyScheme};
use crate::observable::Observable;
use sdae_mlmc::MlmcError;
use sdae_mlmc::block::BLOCK;
use sdae_mlmc::qmc::QuasiSampler;
use sdae_mlmc::sampler::LevelSampler;
use sdae_mlmc::sums::Sample;

/// Fine steps drawn at once.
const CHUNK: usize = 256;

/// Sample indices per level: sample i of level l is stream l 2^48 + i.
const SAMPLES_PER_LEVEL: u64 = 1 << 48;

/// |r_i| or |v_i| above this at the end of a path counts as a blow-up.
const BLOW_UP: f64 = 1e8;

/// The level sampler of a scene's system with one scheme.
pub struct CoupledSampler<S> {
    scheme: StudyScheme<S>,
    start: (Vec<f64>, Vec<f64>),
    t_end: f64,
    coarsest: u32,
    observable: Observable,
    seed: u64,
    antithetic: bool,
}

/// A worker thread's ensembles: the fine paths, their antithetic twins and the coarse paths.
pub struct Worker<S> {
    fine: BoxedEnsemble<S>,
    twin: BoxedEnsemble<S>,
    coarse: BoxedEnsemble<S>,
    increments: LineVec<f64>,
    sum: Vec<f64>,
    rows: Vec<f64>,
    /// The scrambled points of the last (level, randomization) run on quasi-random paths.
    quasi: Option<((u32, u32), QuasiBrownian)>,
}

impl<S> CoupledSampler<S> {
    /// Pairs of `scheme` from (r0, v0) = `start` to T = `t_end`, level 0 on 2^`coarsest`
    /// steps, estimating `observable`, streams from `seed`; antithetic fine paths if asked.
    pub fn new(
        scheme: StudyScheme<S>, start: (Vec<f64>, Vec<f64>), t_end: f64, coarsest: u32,
        observable: Observable, seed: u64, antithetic: bool,
    ) -> Self {
        Self {
            scheme,
            start,
            t_end,
            coarsest,
            observable,
            seed,
            antithetic,
        }
    }

    /// The scheme's name.
    pub fn scheme_name(&self) -> &str {
        self.scheme.name()
    }

    /// Whether the fine paths are antithetic.
    pub fn antithetic(&self) -> bool {
        self.antithetic
    }
}

/// f at the end of each path of `ensemble`, or why it has none (a failed step, a state beyond
/// [`BLOW_UP`] or not finite).
fn finals<S: sdae_model::System>(
    ensemble: &dyn PathEnsemble<System = S>, observable: &Observable, rows: &mut Vec<f64>,
) -> Result<Vec<Option<f64>>, MlmcError> {
    let n = ensemble.system().constraint().dim();
    let paths: Vec<usize> = (0..BLOCK as usize).collect();
    rows.resize(2 * n * paths.len(), 0.0);
    ensemble
        .read_rows(&paths, 0, rows)
        .map_err(crate::error::StudyError::from)?;
    let mut out = Vec::with_capacity(paths.len());
    for (p, row) in paths.iter().zip(rows.chunks_exact(2 * n)) {
        let failed = ensemble
            .failure(*p)
            .map_err(crate::error::StudyError::from)?
            .is_some();
        let bounded = row.iter().all(|x| x.abs() <= BLOW_UP);
        let value = observable.value(&row[..n], &row[n..]);
        out.push((!failed && bounded && value.is_finite()).then_some(value));
    }
    Ok(out)
}

use sdae_manifold::Constraint as _;

impl<S: sdae_model::System> Worker<S> {
    /// The samples of a block from its paths' ends: the fine value (the mean with the twin's
    /// if it ran) and the coarse one (0 without a coarse path), or which of them failed.
    fn samples(
        &mut self, observable: &Observable, pair: bool, twin: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        let fine = finals(self.fine.as_ref(), observable, &mut self.rows)?;
        let coarse = if pair {
            finals(self.coarse.as_ref(), observable, &mut self.rows)?
        } else {
            vec![Some(0.0); fine.len()]
        };
        let twins = if twin {
            finals(self.twin.as_ref(), observable, &mut self.rows)?
        } else {
            fine.clone()
        };
        Ok(fine
            .iter()
            .zip(&twins)
            .zip(&coarse)
            .map(|((f, t), c)| match (f.zip(*t), c) {
                (Some((f, t)), Some(c)) => Sample::Value {
                    fine: if twin { 0.5 * (f + t) } else { f },
                    coarse: *c,
                },
                (fine, coarse) => Sample::Failed {
                    fine: fine.is_none(),
                    coarse: coarse.is_none(),
                },
            })
            .collect())
    }
}

impl<S> CoupledSampler<S>
where
    S: sdae_model::System + Send + Sync + 'static,
{
    /// The samples of one block of level `level` whose fine increments come from `noise`
    /// (one path per sample): the fine path takes them in order, the coarse path one step of
    /// 2 h with the sum of each two, the antithetic twin the two in swapped order.
    fn run_pairs(
        &self, worker: &mut Worker<S>, level: u32, coupled: bool, noise: &mut dyn EnsembleNoise,
    ) -> Result<Vec<Sample>, MlmcError> {
        let study = |e: sdae_model::ModelError| MlmcError::from(crate::error::StudyError::from(e));
        let (r0, v0) = (&self.start.0[..], &self.start.1[..]);
        let pair = coupled && level > 0;
        let twin = pair && self.antithetic;
        worker.fine.restart(r0, v0).map_err(study)?;
        if pair {
            worker.coarse.restart(r0, v0).map_err(study)?;
        }
        if twin {
            worker.twin.restart(r0, v0).map_err(study)?;
        }
        let width = noise.dim() * worker.fine.stride();
        let steps = 1usize << (self.coarsest + level);
        let h = self.t_end / steps as f64;
        let chunk = CHUNK.min(steps);
        worker.increments.resize(chunk * width, 0.0);
        worker.sum.resize(width, 0.0);
        for _ in 0..steps / chunk {
            noise
                .fill(h, &mut worker.increments)
                .map_err(|e| study(e.into()))?;
            let dw = &worker.increments;
            if !pair {
                for k in 0..chunk {
                    worker
                        .fine
                        .step(h, &dw[k * width..(k + 1) * width])
                        .map_err(study)?;
                }
                continue;
            }
            for k in (0..chunk).step_by(2) {
                let (a, b) = (
                    &dw[k * width..(k + 1) * width],
                    &dw[(k + 1) * width..(k + 2) * width],
                );
                worker.fine.step(h, a).map_err(study)?;
                worker.fine.step(h, b).map_err(study)?;
                for ((s, x), y) in worker.sum.iter_mut().zip(a).zip(b) {
                    *s = x + y;
                }
                worker.coarse.step(2.0 * h, &worker.sum).map_err(study)?;
                if twin {
                    worker.twin.step(h, b).map_err(study)?;
                    worker.twin.step(h, a).map_err(study)?;
                }
            }
        }
        worker.samples(&self.observable, pair, twin)
    }

    /// The samples `points` (at most [`BLOCK`], below 2^32) of randomization `randomization`
    /// of level `level`: sample i's fine increments are point i of that randomization's
    /// scrambled Sobol' points laid out by a Brownian bridge on the fine grid
    /// ([`QuasiBrownian`], seeded by (seed, level 2^32 + randomization)), coupled as
    /// [`LevelSampler::run_block`] couples them. A block of fewer points fills the ensembles'
    /// further paths with its first point (run, not returned). The worker keeps the last
    /// randomization's scrambled points.
    fn run_quasi_block(
        &self, worker: &mut Worker<S>, level: u32, randomization: u32, points: Range<u64>,
        coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        let count = points.end.saturating_sub(points.start);
        if points.end > 1 << 32 || count == 0 || count > BLOCK {
            return Err(MlmcError::Setting {
                key: "points",
                value: format!("{}..{}", points.start, points.end),
                rule: format!("blocks of 1 to {BLOCK} points below 2^32 per randomization"),
            });
        }
        let noise_error = |e: sdae_noise::NoiseError| {
            MlmcError::from(crate::error::StudyError::from(
                sdae_model::ModelError::from(e),
            ))
        };
        let key = (level, randomization);
        let mut indices: Vec<u64> = points.clone().collect();
        indices.resize(BLOCK as usize, points.start);
        let mut noise = match &worker.quasi {
            Some((k, quasi)) if *k == key => quasi.ensemble(&indices),
            _ => {
                let steps = 1usize << (self.coarsest + level);
                let l = worker.fine.system().noise_dim();
                let stream = (u64::from(level) << 32) | u64::from(randomization);
                let quasi = QuasiBrownian::new(self.seed, stream, l, steps).map_err(noise_error)?;
                let noise = quasi.ensemble(&indices);
                worker.quasi = Some((key, quasi));
                noise
            }
        }
        .map_err(noise_error)?;
        let mut samples = self.run_pairs(worker, level, coupled, &mut noise)?;
        samples.truncate(count as usize);
        Ok(samples)
    }
}

/// Multilevel randomized QMC: path i of randomization r of a level is point i of its scrambled
/// Sobol' points (`run_quasi_block`, below).
impl<S> QuasiSampler for CoupledSampler<S>
where
    S: sdae_model::System + Send + Sync + 'static,
{
    type Worker = Worker<S>;

    fn worker(&self) -> Result<Worker<S>, MlmcError> {
        LevelSampler::worker(self)
    }

    fn run_points(
        &self, worker: &mut Worker<S>, level: u32, randomization: u32, points: Range<u64>,
        coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        self.run_quasi_block(worker, level, randomization, points, coupled)
    }

    fn path_steps(&self, level: u32) -> u64 {
        LevelSampler::path_steps(self, level)
    }

    fn pair_steps(&self, level: u32) -> u64 {
        LevelSampler::pair_steps(self, level)
    }

    /// l 2^(k0 + level) coordinates, at most [`MAX_SOBOL_DIMS`] of them quasi-random.
    fn coordinates(&self, level: u32) -> Option<(u64, u64)> {
        let (r0, v0) = (&self.start.0[..], &self.start.1[..]);
        let l = self
            .scheme
            .build_ensemble(1, r0, v0)
            .ok()?
            .system()
            .noise_dim() as u64;
        let total = l.checked_mul(LevelSampler::path_steps(self, level))?;
        Some((total, total.min(MAX_SOBOL_DIMS as u64)))
    }
}

impl<S> LevelSampler for CoupledSampler<S>
where
    S: sdae_model::System + Send + Sync + 'static,
{
    type Worker = Worker<S>;

    fn worker(&self) -> Result<Worker<S>, MlmcError> {
        let (r0, v0) = (&self.start.0[..], &self.start.1[..]);
        let build = || self.scheme.build_ensemble(BLOCK as usize, r0, v0);
        Ok(Worker {
            fine: build()?,
            twin: build()?,
            coarse: build()?,
            increments: LineVec::new(),
            sum: Vec::new(),
            rows: Vec::new(),
            quasi: None,
        })
    }

    fn run_block(
        &self, worker: &mut Worker<S>, level: u32, indices: Range<u64>, coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        if indices.end > SAMPLES_PER_LEVEL || indices.end - indices.start != BLOCK {
            return Err(MlmcError::Setting {
                key: "samples",
                value: indices.end.to_string(),
                rule: format!("blocks of {BLOCK} samples below 2^48 per level"),
            });
        }
        let streams: Vec<u64> = indices
            .map(|i| u64::from(level) * SAMPLES_PER_LEVEL + i)
            .collect();
        let l = worker.fine.system().noise_dim();
        let mut noise = EnsembleIncrements::for_paths(self.seed, &streams, l);
        self.run_pairs(worker, level, coupled, &mut noise)
    }

    fn path_steps(&self, level: u32) -> u64 {
        1 << (self.coarsest + level)
    }

    fn pair_steps(&self, level: u32) -> u64 {
        let fine = LevelSampler::path_steps(self, level);
        match level {
            0 => fine,
            _ if self.antithetic => 2 * fine + fine / 2,
            _ => fine + fine / 2,
        }
    }
}
