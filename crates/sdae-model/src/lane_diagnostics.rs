//! The [`PathDiagnostics`] of many paths in columns (structure-of-arrays layout, one value per
//! path and field), recorded W lanes at a time from what a lane form decided
//! ([`LaneRecord`]), with the floating-point operations of [`PathDiagnostics::record`] in the
//! same order: a path's diagnostics are those of its steps recorded one at a time, whether
//! its steps went through the lanes or through the scalar step.

use pulp::Simd;
use sdae_lanes::{LaneMask, Lanes, LineVec};

use crate::diagnostics::{ITERATION_BINS, PathDiagnostics};
use crate::error::{ModelError, try_lines};
use crate::scheme::StepOutcome;

/// What [`PathDiagnostics::record`] reads of the [`StepOutcome`]s of W lanes' steps, per lane.
#[derive(Debug, Clone, Copy)]
pub struct LaneRecord<Sd: Simd> {
    /// [`StepOutcome::eta`].
    pub eta: Lanes<Sd>,
    /// [`StepOutcome::newton_iterations`], as whole numbers.
    pub newton_iterations: Lanes<Sd>,
    /// [`StepOutcome::position_residual`], where the scheme measured it.
    pub position_residual: Option<Lanes<Sd>>,
    /// [`StepOutcome::velocity_residual`], where the scheme measured it.
    pub velocity_residual: Option<Lanes<Sd>>,
    /// The certificate's contraction estimate and, where its radius C_kappa is finite,
    /// |kappa| / C_kappa (`norm / radius`); `None` without a certificate. Lanes never take the
    /// homotopy nor certify with a rounding correction.
    pub certificate: Option<(Lanes<Sd>, Option<Lanes<Sd>>)>,
}

impl<Sd: Simd> LaneRecord<Sd> {
    /// The record of [`StepOutcome::PLAIN`] steps with the truncation factors `eta`.
    #[inline(always)]
    pub fn plain(eta: Lanes<Sd>) -> Self {
        Self {
            eta,
            newton_iterations: eta.splat_like(0.0),
            position_residual: None,
            velocity_residual: None,
            certificate: None,
        }
    }
}

/// [`PathDiagnostics`] of the paths of a `stride`-wide layout, field by field; counts are
/// whole numbers held as f64 (exact below 2^53).
#[derive(Debug, Clone)]
pub(crate) struct DiagnosticsColumns {
    stride: usize,
    steps: LineVec<f64>,
    truncated_steps: LineVec<f64>,
    min_eta: LineVec<f64>,
    newton_iterations: LineVec<f64>,
    /// Bin b of path p at `b * stride + p`.
    iteration_histogram: LineVec<f64>,
    homotopy_steps: LineVec<f64>,
    max_position_residual: LineVec<f64>,
    max_velocity_residual: LineVec<f64>,
    max_kappa_ratio: LineVec<f64>,
    max_contraction: LineVec<f64>,
    clock_lag: LineVec<f64>,
    rounding_certified_steps: LineVec<f64>,
}

impl DiagnosticsColumns {
    /// Fresh diagnostics of the paths of a layout of width `stride`
    /// ([`ModelError::Allocation`] if they do not fit in memory).
    pub(crate) fn new(stride: usize) -> Result<Self, ModelError> {
        let what = "the lanes' diagnostics";
        let column = || try_lines(what, 0.0, 1, stride);
        let mut columns = Self {
            stride,
            steps: column()?,
            truncated_steps: column()?,
            min_eta: column()?,
            newton_iterations: column()?,
            iteration_histogram: try_lines(what, 0.0, ITERATION_BINS, stride)?,
            homotopy_steps: column()?,
            max_position_residual: column()?,
            max_velocity_residual: column()?,
            max_kappa_ratio: column()?,
            max_contraction: column()?,
            clock_lag: column()?,
            rounding_certified_steps: column()?,
        };
        columns.reset();
        Ok(columns)
    }

    /// Every path's diagnostics back to those of a path that has taken no step.
    pub(crate) fn reset(&mut self) {
        let fresh = PathDiagnostics::default();
        for column in [
            &mut self.steps,
            &mut self.truncated_steps,
            &mut self.newton_iterations,
            &mut self.iteration_histogram,
            &mut self.homotopy_steps,
            &mut self.rounding_certified_steps,
        ] {
            column.fill(0.0);
        }
        self.min_eta.fill(fresh.min_eta);
        self.max_position_residual.fill(fresh.max_position_residual);
        self.max_velocity_residual.fill(fresh.max_velocity_residual);
        self.max_kappa_ratio.fill(fresh.max_kappa_ratio);
        self.max_contraction.fill(fresh.max_contraction);
        self.clock_lag.fill(fresh.clock_lag);
    }

    /// Path p's diagnostics.
    pub(crate) fn get(&self, p: usize) -> PathDiagnostics {
        let mut iteration_histogram = [0; ITERATION_BINS];
        for (b, count) in iteration_histogram.iter_mut().enumerate() {
            *count = self.iteration_histogram[b * self.stride + p] as usize;
        }
        PathDiagnostics {
            steps: self.steps[p] as usize,
            truncated_steps: self.truncated_steps[p] as usize,
            min_eta: self.min_eta[p],
            newton_iterations: self.newton_iterations[p] as usize,
            iteration_histogram,
            homotopy_steps: self.homotopy_steps[p] as usize,
            max_position_residual: self.max_position_residual[p],
            max_velocity_residual: self.max_velocity_residual[p],
            max_kappa_ratio: self.max_kappa_ratio[p],
            max_contraction: self.max_contraction[p],
            clock_lag: self.clock_lag[p],
            rounding_certified_steps: self.rounding_certified_steps[p] as usize,
        }
    }

    /// Sets path p's diagnostics.
    fn set(&mut self, p: usize, d: &PathDiagnostics) {
        for (b, &count) in d.iteration_histogram.iter().enumerate() {
            self.iteration_histogram[b * self.stride + p] = count as f64;
        }
        self.steps[p] = d.steps as f64;
        self.truncated_steps[p] = d.truncated_steps as f64;
        self.min_eta[p] = d.min_eta;
        self.newton_iterations[p] = d.newton_iterations as f64;
        self.homotopy_steps[p] = d.homotopy_steps as f64;
        self.max_position_residual[p] = d.max_position_residual;
        self.max_velocity_residual[p] = d.max_velocity_residual;
        self.max_kappa_ratio[p] = d.max_kappa_ratio;
        self.max_contraction[p] = d.max_contraction;
        self.clock_lag[p] = d.clock_lag;
        self.rounding_certified_steps[p] = d.rounding_certified_steps as f64;
    }

    /// Adds path p's step of size h ([`PathDiagnostics::record`]).
    pub(crate) fn record(&mut self, p: usize, outcome: &StepOutcome, h: f64) {
        let mut d = self.get(p);
        d.record(outcome, h);
        self.set(p, &d);
    }

    /// Adds the step of size h of each lane of `done` in the group of paths `offset..offset +
    /// W`: [`PathDiagnostics::record`] over lanes.
    #[inline(always)]
    pub(crate) fn record_lanes<Sd: Simd>(
        &mut self, offset: usize, done: LaneMask<Sd>, record: &LaneRecord<Sd>, h: f64,
    ) {
        let simd = done.simd();
        let zero = Lanes::splat(simd, 0.0);
        let one = zero.splat_like(1.0);
        add(&mut self.steps[offset..], Lanes::select(done, one, zero));
        let lag = Lanes::load(simd, &self.clock_lag[offset..]);
        Lanes::select(done, lag + (one - record.eta) * h, lag).store(&mut self.clock_lag[offset..]);
        add(
            &mut self.truncated_steps[offset..],
            Lanes::select(done.and(record.eta.lt(one)), one, zero),
        );
        let min_eta = Lanes::load(simd, &self.min_eta[offset..]);
        Lanes::select(done.and(record.eta.lt(min_eta)), record.eta, min_eta)
            .store(&mut self.min_eta[offset..]);
        add(
            &mut self.newton_iterations[offset..],
            Lanes::select(done, record.newton_iterations, zero),
        );
        self.count_iterations(offset, done, record.newton_iterations);
        if let Some(residual) = record.position_residual {
            raise(&mut self.max_position_residual[offset..], done, residual);
        }
        if let Some(residual) = record.velocity_residual {
            raise(&mut self.max_velocity_residual[offset..], done, residual);
        }
        if let Some((contraction, kappa_ratio)) = record.certificate {
            if let Some(ratio) = kappa_ratio {
                raise(&mut self.max_kappa_ratio[offset..], done, ratio);
            }
            raise(&mut self.max_contraction[offset..], done, contraction);
        }
    }

    /// The histogram's bins of the lanes of `done`: one bin when every lane of the group took
    /// the same number of iterations (the closed forms: 0), else lane by lane.
    #[inline(always)]
    fn count_iterations<Sd: Simd>(
        &mut self, offset: usize, done: LaneMask<Sd>, iterations: Lanes<Sd>,
    ) {
        let last = (ITERATION_BINS - 1) as f64;
        let first = iterations.lane(0);
        let bin_of = |count: f64| count.min(last) as usize;
        if iterations.eq(iterations.splat_like(first)).all() {
            let at = bin_of(first) * self.stride + offset;
            let column = &mut self.iteration_histogram[at..];
            let counted =
                Lanes::select(done, iterations.splat_like(1.0), iterations.splat_like(0.0));
            add(column, counted);
            return;
        }
        for lane in 0..Sd::F64_LANES {
            if done.lane(lane) {
                let at = bin_of(iterations.lane(lane)) * self.stride + offset + lane;
                self.iteration_histogram[at] += 1.0;
            }
        }
    }
}

/// column[..W] += x. A function, not a closure: it inherits the caller's instruction set.
#[inline(always)]
fn add<Sd: Simd>(column: &mut [f64], x: Lanes<Sd>) {
    (Lanes::load(x.simd(), column) + x).store(column);
}

/// column[..W] = x in the lanes of `done` where x is larger (f64::max, which passes over a NaN
/// x).
#[inline(always)]
fn raise<Sd: Simd>(column: &mut [f64], done: LaneMask<Sd>, x: Lanes<Sd>) {
    let old = Lanes::load(x.simd(), column);
    Lanes::select(done.and(old.lt(x)), x, old).store(column);
}

#[cfg(test)]
mod tests {
    use super::*;
    use pulp::WithSimd;
    use sdae_ift::{Certificate, Method};
    use sdae_lanes::LaneWidth;

    /// The outcome of step k of lane `lane`: truncated or not, 0 to 20 iterations, a NaN
    /// contraction now and then (no probes), a finite or infinite radius.
    fn outcome(k: usize, lane: usize, radius: f64) -> StepOutcome {
        let x = ((k * 7 + lane * 13) % 17) as f64;
        StepOutcome {
            eta: if x < 6.0 { 0.1 + x / 7.0 } else { 1.0 },
            newton_iterations: if k.is_multiple_of(5) {
                3
            } else {
                (k + lane) % 21
            },
            certificate: Some(Certificate {
                iterations: 0,
                homotopy_steps: 0,
                method: Method::Newton,
                residual: x * 1e-16,
                norm: x * 1e-3,
                radius,
                first_step: x * 1e-3,
                contraction: if x == 4.0 { f64::NAN } else { x / 40.0 },
                rounding: 0.0,
            }),
            position_residual: Some(x * 1e-16),
            velocity_residual: Some((16.0 - x) * 1e-15),
        }
    }

    /// Records 40 steps of a 2W-lane layout in lanes (each lane done on most steps) and the
    /// same outcomes one by one with `PathDiagnostics::record`: the same bits.
    struct Check {
        radius: f64,
    }

    impl WithSimd for Check {
        type Output = ();
        fn with_simd<S: Simd>(self, simd: S) {
            let width = Lanes::<S>::WIDTH;
            let stride = 2 * width;
            let h = 0.01;
            let mut columns = DiagnosticsColumns::new(stride).expect("a small layout");
            let mut expected = vec![PathDiagnostics::default(); stride];
            let lanes_of = |f: &dyn Fn(usize) -> f64, offset: usize| {
                let values: Vec<f64> = (0..width).map(|lane| f(offset + lane)).collect();
                Lanes::load(simd, &values)
            };
            for k in 0..40 {
                for offset in [0, width] {
                    let done_values = lanes_of(&|p| ((k + p) % 4 != 0) as u8 as f64, offset);
                    let done = done_values.eq(done_values.splat_like(1.0));
                    let at = |p: usize| outcome(k, p, self.radius);
                    let certificate = |p: usize| at(p).certificate.unwrap();
                    let record = LaneRecord {
                        eta: lanes_of(&|p| at(p).eta, offset),
                        newton_iterations: lanes_of(&|p| at(p).newton_iterations as f64, offset),
                        position_residual: Some(lanes_of(
                            &|p| at(p).position_residual.unwrap(),
                            offset,
                        )),
                        velocity_residual: Some(lanes_of(
                            &|p| at(p).velocity_residual.unwrap(),
                            offset,
                        )),
                        certificate: Some((
                            lanes_of(&|p| certificate(p).contraction, offset),
                            self.radius.is_finite().then(|| {
                                lanes_of(&|p| certificate(p).norm / certificate(p).radius, offset)
                            }),
                        )),
                    };
                    columns.record_lanes(offset, done, &record, h);
                    for lane in 0..width {
                        if done.lane(lane) {
                            expected[offset + lane].record(&at(offset + lane), h);
                        }
                    }
                }
            }
            for (p, expected) in expected.iter().enumerate() {
                let got = columns.get(p);
                assert_eq!(format!("{got:?}"), format!("{expected:?}"), "path {p}");
                assert_eq!(got.clock_lag.to_bits(), expected.clock_lag.to_bits());
            }
            // A scalar step recorded into the columns goes on from the lanes' record.
            let step = outcome(3, 1, self.radius);
            columns.record(1, &step, h);
            expected[1].record(&step, h);
            assert_eq!(
                format!("{:?}", columns.get(1)),
                format!("{:?}", expected[1])
            );
        }
    }

    #[test]
    fn lanes_record_what_path_diagnostics_record_bit_for_bit() {
        for radius in [f64::INFINITY, 0.05] {
            for width in LaneWidth::ALL {
                width.dispatch(Check { radius });
            }
        }
    }
}
