//! What the benchmarks of one path's steps share: the check and summary of the reset period
//! they run once before measuring.

/// Panics unless `worst`, the largest position residual |g| over a verification period of
/// `steps` steps, is below `bound`; then prints it with the mean number of Newton iterations
/// per step (`iterations`, their sum over the period, divided by `steps`).
pub fn report_verification(name: &str, worst: f64, iterations: usize, steps: usize, bound: f64) {
    assert!(
        worst < bound,
        "{name}: position residual {worst:e} after {steps} steps"
    );
    eprintln!(
        "{name}: {steps} verification steps ok, max |g| = {worst:.1e}, \
         mean Newton iterations per step = {:.2}",
        iterations as f64 / steps as f64
    );
}
