//! The one-uniform model of the QMC and estimator-choice tests: P_l(u) = e^u + c 2^-l u on
//! level l (E\[P_l\] = e - 1 + c 2^-l / 2), the uniforms of its points from SplitMix64 bits,
//! and the worker of a sampler that needs none.

/// P_l(u) = e^u + c 2^-l u, the value of a path of level `level` with uniform `u`.
pub fn rule(c: f64, level: u32, u: f64) -> f64 {
    u.exp() + c * 0.5f64.powi(level as i32) * u
}

/// SplitMix64: a well-mixed 64-bit hash.
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform in [0, 1) from the top 53 of 64 bits.
pub fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 * 2f64.powi(-53)
}

/// The worker of a sampler whose samples need no state of their own (`type Worker = ()`), in
/// its `LevelSampler` or `QuasiSampler` impl.
macro_rules! no_worker {
    () => {
        type Worker = ();
        fn worker(&self) -> Result<(), sdae_mlmc::MlmcError> {
            Ok(())
        }
    };
}

pub(crate) use no_worker;
