//! Shard files: the paths of one shard of a convergence run, or the blocks of one shard of an
//! MLMC plan, as sealed JSON files ([`crate::sealed`]: the shard under `content`, with a
//! checksum of the file on its last line, verified before `merge` and `mlmc-merge` take it).
//!
//! A file that fails its checksum (or has none: written by an older version) is a
//! [`StudyError::Checksum`], one that is no shard a [`StudyError::Read`]. The records of a
//! convergence shard are checked when merged
//! ([`merge_runs`](sdae_study::convergence::merge_runs)).

use std::path::Path;

use sdae_study::StudyError;
use sdae_study::convergence::ConvergenceRun;
use sdae_study::mlmc::shard::MlmcShard;

use crate::sealed::{read_sealed, write_sealed};

/// The format of a convergence shard's file.
const CONVERGENCE_FORMAT: &str = "sdae-study shard 2";

/// The format of an MLMC shard's file.
const MLMC_FORMAT: &str = "sdae-study mlmc shard 2";

/// Writes `run` as the shard file `path` (atomically, with its checksum).
pub fn write_convergence(run: &ConvergenceRun, path: &Path) -> Result<(), StudyError> {
    write_sealed(path, CONVERGENCE_FORMAT, run)
}

/// Reads the convergence shard file `path` written by [`write_convergence`].
pub fn read_convergence(path: &Path) -> Result<ConvergenceRun, StudyError> {
    read_sealed(path, CONVERGENCE_FORMAT)
}

/// Writes `shard` as the MLMC shard file `path` (atomically, with its checksum).
pub fn write_mlmc(shard: &MlmcShard, path: &Path) -> Result<(), StudyError> {
    write_sealed(path, MLMC_FORMAT, shard)
}

/// Reads the MLMC shard file `path` written by [`write_mlmc`].
pub fn read_mlmc(path: &Path) -> Result<MlmcShard, StudyError> {
    read_sealed(path, MLMC_FORMAT)
}
