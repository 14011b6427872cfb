//! Weak orders fitted over the asymptotic levels only.
//!
//! The levels considered are those whose error is resolved (|e| above the half-width of its
//! interval, which includes the reference's bias bound, and a normal float: an error that
//! underflowed to zero or a subnormal is unresolved). From them, coarse to fine, the
//! coarsest is left out as pre-asymptotic while
//!
//! - it lies before a change of sign of the error (a zero crossing of e(h) is no sign of
//!   accuracy: the fit of log |e| needs one sign; where the two finest levels differ in sign
//!   there is no order), or
//! - its local slope log(|e_a| / |e_b|) / log(h_a / h_b) to the next level differs from the
//!   least-squares slope of the finer levels by more than the strong study's tolerance
//!   ([`crate::PRE_ASYMPTOTIC_TOLERANCE`], 0.05) and
//!   beyond the Monte Carlo error (the 95% bootstrap interval of the difference excludes 0),
//!   as long as three levels remain,
//!
//! which is the strong study's rule ([`crate::fit_order`]) for signed errors. The
//! order is the least-squares slope of log |e| against log h over the remaining levels.
//!
//! The order's interval is the bootstrap interval of the slope, widened by the model error
//! that the levels show:
//!
//! - at least +-0.05, the tolerance above: the rule takes local slopes that differ by less for
//!   one order, so the fit does not tell orders apart more finely;
//! - after a change of sign, the error is not yet a power law: e(h) = c h^p (1 - h / h0) with
//!   its zero at h0 has the local slope p + log2((1 - 2x) / (1 - x)) between 2h and h, x = h /
//!   h0. With h0 taken at the first fitted level (the sign changed before it, so h0 is at
//!   least that coarse, and x at most what this takes), the finest local slope's interval is
//!   widened by |log2((1 - 2x) / (1 - x))|; with fewer than three levels after the change
//!   (x > 1/4) the levels do not tell the order at all;
//! - where the local slopes do not settle ([`WeakOrder::unsettled`]: the last change beyond
//!   the Monte Carlo error and 0.05, and no smaller than the one before), the levels tell no
//!   order at all;
//! - where the local slope still changes beyond the Monte Carlo error between the two finest
//!   pairs of fitted levels (the order's `bending`), the finest local slope's interval moved
//!   by that change either way: an error e(h) = c h^p (1 + d h + ...) that is not yet a power
//!   law has local slopes s_k that approach p like 2^-k, so what is left of the approach after
//!   the finest pair is about the last change s_k - s_(k-1).
//!
//! - where the levels cannot show the asymptote, the levels tell no order
//!   ([`WeakOrder::unshown`]): two fitted levels, whose one local slope cannot be compared with
//!   another; or three whose one change of local slope the Monte Carlo error leaves unknown to
//!   within an order (its 95% interval reaches beyond +-[`MAX_UNSHOWN_CHANGE`]). Within that
//!   reach, a change of three levels' slopes that the Monte Carlo error hides widens the finest
//!   local slope's interval by its reach, as a resolved one does by its size. Resolved near their half-widths,
//!   a few coarse levels share one Monte Carlo offset, which steepens or flattens every local
//!   slope alike: a bootstrap interval of the fit alone then excludes the true order.
//!
//! So the verdict covers the model error too, instead of a tight interval around a slope that
//! is still moving. All intervals come from one bootstrap over whole paths
//! (the study's path bootstrap), so the correlation between levels is kept.

use serde::Serialize;

use crate::{Interval, PRE_ASYMPTOTIC_TOLERANCE};

/// The largest reach of the 95% interval of the change between the local slopes of three
/// fitted levels with which they still show the asymptote (one order).
pub const MAX_UNSHOWN_CHANGE: f64 = 1.0;

/// The slope between two neighbouring fitted levels, with its 95% bootstrap interval.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeakSlope {
    /// Index of the coarser level (into the row's levels).
    pub coarse: usize,
    /// Index of the finer level.
    pub fine: usize,
    /// log(|e_coarse| / |e_fine|) / log(h_coarse / h_fine).
    pub slope: Interval,
}

/// A fitted weak order.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeakOrder {
    /// Least-squares slope of log |e| against log h over the fitted levels, with its 95%
    /// bootstrap interval over whole paths widened by the model error (module documentation);
    /// `None` where too few levels follow a change of sign of the error to tell the order.
    pub order: Option<Interval>,
    /// Indices (into the row's levels) of the levels fitted: resolved and asymptotic.
    pub fitted: Vec<usize>,
    /// Indices of the levels whose error is not resolved: |e| within the half-width of its
    /// interval (the Monte Carlo error plus the reference's bias bound).
    pub unresolved: Vec<usize>,
    /// Indices of the coarse levels left out as pre-asymptotic (module documentation).
    pub pre_asymptotic: Vec<usize>,
    /// Local slopes between neighbouring resolved levels, coarse to fine.
    pub local_slopes: Vec<WeakSlope>,
    /// The local slopes do not settle: their change between the two finest pairs is beyond the
    /// Monte Carlo error and the tolerance 0.05, and no smaller than the change before it (approaching an order, the
    /// changes shrink, about by half a level). The levels then tell no order.
    pub unsettled: bool,
    /// The fitted levels cannot show the asymptote: two of them, or three whose change of local
    /// slope has a 95% interval reaching beyond +-[`MAX_UNSHOWN_CHANGE`]. The levels then tell
    /// no order.
    pub unshown: bool,
    /// Where the local slope still changes between the two finest pairs of fitted levels
    /// beyond the Monte Carlo error: that change (module documentation). The order's interval
    /// includes the finest local slope's interval widened by it on each side.
    pub bending: Option<f64>,
    /// Where the error changed sign before the fitted levels: how far the finest local slope
    /// can still be from the order (module documentation). The order's interval includes the
    /// finest local slope's interval widened by it on each side.
    pub after_crossing: Option<f64>,
}

/// The least-squares slope of log |e_j| against log h_j over `levels` (NaN with fewer than 2).
pub fn log_slope(h: &[f64], e: &[f64], levels: &[usize]) -> f64 {
    if levels.len() < 2 {
        return f64::NAN;
    }
    let x: Vec<f64> = levels.iter().map(|&j| h[j].ln()).collect();
    let y: Vec<f64> = levels.iter().map(|&j| e[j].abs().ln()).collect();
    let mx = x.iter().sum::<f64>() / x.len() as f64;
    let my = y.iter().sum::<f64>() / y.len() as f64;
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// The slopes a weak order is chosen from, over the resolved levels `usable` (coarse to fine,
/// m of them): the slope over each run of finer levels `usable[k..]` (k < m - 1), the local
/// slope of each neighbouring pair, the difference between the local slope of `usable[k]`,
/// `usable[k + 1]` and the slope over `usable[k + 1..]` (k < m - 2), and the change between
/// neighbouring local slopes (k < m - 2). Laid out in that order in the statistic a bootstrap
/// resamples ([`OrderCandidates::push`]).
pub struct OrderCandidates<'a> {
    h: &'a [f64],
    usable: Vec<usize>,
    unresolved: Vec<usize>,
}

impl<'a> OrderCandidates<'a> {
    /// The candidates over the levels of step sizes `h` whose error is resolved.
    pub fn new(h: &'a [f64], resolved: impl Fn(usize) -> bool) -> Self {
        let (usable, unresolved) = (0..h.len()).partition(|&j| resolved(j));
        Self {
            h,
            usable,
            unresolved,
        }
    }

    /// Values this adds to a statistic.
    pub fn len(&self) -> usize {
        let m = self.usable.len();
        if m < 2 { 0 } else { 2 * (m - 1) + 2 * (m - 2) }
    }

    /// Whether this adds nothing (fewer than two resolved levels).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Appends the candidates' values for the errors `e` (one per level) to `out`.
    pub fn push(&self, e: &[f64], out: &mut Vec<f64>) {
        let (u, h) = (&self.usable, self.h);
        if u.len() < 2 {
            return;
        }
        let suffix = |k: usize| log_slope(h, e, &u[k..]);
        let local = |k: usize| log_slope(h, e, &u[k..k + 2]);
        out.extend((0..u.len() - 1).map(suffix));
        out.extend((0..u.len() - 1).map(local));
        out.extend((0..u.len() - 2).map(|k| local(k) - suffix(k + 1)));
        out.extend((0..u.len() - 2).map(|k| local(k + 1) - local(k)));
    }

    /// The order from the errors `e` of all paths and the bootstrap `intervals` of the values
    /// [`OrderCandidates::push`] gives (in its layout): the pre-asymptotic levels dropped as the
    /// module documentation says. `None` with fewer than two resolved levels or where the two
    /// finest differ in sign.
    pub fn choose(&self, e: &[f64], intervals: &[Option<Interval>]) -> Option<WeakOrder> {
        let (u, m) = (&self.usable, self.usable.len());
        if m < 2 || intervals.len() != self.len() {
            return None;
        }
        let (suffix, rest) = intervals.split_at(m - 1);
        let (local, rest) = rest.split_at(m - 1);
        let (differences, changes) = rest.split_at(m - 2);
        // Every level up to the last change of sign, then coarse levels off the finer slope.
        let after_sign = (0..m - 1)
            .rev()
            .find(|&k| e[u[k]].signum() != e[u[k + 1]].signum())
            .map_or(0, |k| k + 1);
        if m - after_sign < 2 {
            return None;
        }
        let start = first_asymptotic(after_sign, m, differences);
        // The change of the local slope between the two finest pairs of fitted levels: its size
        // where resolved, the reach of its interval where the Monte Carlo error hides it.
        let bending = (m - start >= 3)
            .then(|| changes[m - 3])
            .flatten()
            .filter(|c| !c.contains(0.0))
            .map(|c| c.estimate.abs());
        // Three fitted levels show the asymptote by one comparison, their change of local slope:
        // where the Monte Carlo error hides it, it is known only to within its interval's reach,
        // which must stay within MAX_UNSHOWN_CHANGE and widens the finest local slope's interval.
        let only = (m - start == 3).then(|| changes[m - 3]).flatten();
        let shown = match only {
            _ if m - start >= 4 => true,
            Some(c) => reach(&c) <= MAX_UNSHOWN_CHANGE,
            None => false,
        };
        let hidden = only
            .filter(|c| shown && c.contains(0.0) && reach(c) > PRE_ASYMPTOTIC_TOLERANCE)
            .map(|c| reach(&c));
        // After a change of sign, x = h_finest / h0 with h0 at the first fitted level.
        let crossing = (start > 0 && e[u[start - 1]].signum() != e[u[start]].signum())
            .then(|| self.h[u[m - 1]] / self.h[u[start]]);
        let after_crossing = crossing.map(crossing_widening);
        // Too few levels after a change of sign is the more telling reason.
        let unshown = after_crossing.is_none_or(f64::is_finite) && !shown;
        let unsettled = bending.is_some() && m - after_sign >= 4 && unsettling(changes);
        let order = suffix[start]
            .filter(|_| after_crossing.is_none_or(f64::is_finite))
            .filter(|_| !unsettled && !unshown)
            .map(|order| widened_order(order, local[m - 2], [bending.or(hidden), after_crossing]));
        Some(WeakOrder {
            order,
            unsettled,
            unshown,
            bending,
            after_crossing: after_crossing.filter(|x| x.is_finite()),
            fitted: u[start..].to_vec(),
            unresolved: self.unresolved.clone(),
            pre_asymptotic: u[..start].to_vec(),
            local_slopes: local_slopes(u, local),
        })
    }
}

/// The first level fitted, from `start` (the first after the last change of sign) of `m`
/// resolved levels: coarse levels are left out while their local slope differs from the
/// slope of the finer levels (`differences`) beyond the tolerance and the Monte Carlo error,
/// as long as three levels remain.
fn first_asymptotic(mut start: usize, m: usize, differences: &[Option<Interval>]) -> usize {
    while m - start > 3
        && differences[start]
            .as_ref()
            .is_some_and(|d| d.estimate.abs() > PRE_ASYMPTOTIC_TOLERANCE && !d.contains(0.0))
    {
        start += 1;
    }
    start
}

/// How far an interval of a change of local slopes reaches from 0: the larger of |ends|.
fn reach(change: &Interval) -> f64 {
    change.ci_low.abs().max(change.ci_high.abs())
}

/// How far the finest local slope can still be from the order after a change of sign, for
/// x = h_finest / h0: |log2((1 - 2x) / (1 - x))|, infinite for x > 1/4 (too few levels after
/// the change to tell the order).
fn crossing_widening(x: f64) -> f64 {
    if x > 0.25 {
        f64::INFINITY
    } else {
        ((1.0 - 2.0 * x) / (1.0 - x)).log2().abs()
    }
}

/// Whether the local slopes do not settle (given their `changes`, at least two): their last
/// change is beyond the tolerance and no smaller than the change before.
fn unsettling(changes: &[Option<Interval>]) -> bool {
    let n = changes.len();
    match (changes[n - 1], changes[n - 2]) {
        (Some(last), Some(before)) => {
            last.estimate.abs() > PRE_ASYMPTOTIC_TOLERANCE
                && last.estimate.abs() >= before.estimate.abs()
        }
        _ => false,
    }
}

/// `order`'s interval widened to at least +-[`PRE_ASYMPTOTIC_TOLERANCE`] and, by each of
/// `widenings` that applies, to the `finest` local slope's interval widened by it.
fn widened_order(
    mut order: Interval, finest: Option<Interval>, widenings: [Option<f64>; 2],
) -> Interval {
    let tolerance = PRE_ASYMPTOTIC_TOLERANCE;
    order.ci_low = order.ci_low.min(order.estimate - tolerance);
    order.ci_high = order.ci_high.max(order.estimate + tolerance);
    for widen in widenings.into_iter().flatten() {
        if let Some(finest) = finest {
            order.ci_low = order.ci_low.min(finest.ci_low - widen);
            order.ci_high = order.ci_high.max(finest.ci_high + widen);
        }
    }
    order
}

/// The local slopes between neighbouring levels of `usable` that have an interval in `local`.
fn local_slopes(usable: &[usize], local: &[Option<Interval>]) -> Vec<WeakSlope> {
    usable
        .windows(2)
        .zip(local)
        .filter_map(|(w, slope)| {
            slope.map(|slope| WeakSlope {
                coarse: w[0],
                fine: w[1],
                slope,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Intervals of width `half` around the values of `push` for the errors `e`.
    fn intervals(c: &OrderCandidates<'_>, e: &[f64], half: f64) -> Vec<Option<Interval>> {
        let mut values = Vec::new();
        c.push(e, &mut values);
        values
            .into_iter()
            .map(|x| {
                Some(Interval {
                    estimate: x,
                    ci_low: x - half,
                    ci_high: x + half,
                })
            })
            .collect()
    }

    #[test]
    fn a_coarse_level_off_the_power_law_is_dropped_and_named() {
        // e = h + 4 h^2 at h = 1/4 .. 1/128: the coarse levels fall faster than first order.
        let h: Vec<f64> = (2..8).map(|k| 0.5f64.powi(k)).collect();
        let e: Vec<f64> = h.iter().map(|h| h + 4.0 * h * h).collect();
        let c = OrderCandidates::new(&h, |_| true);
        let fit = c.choose(&e, &intervals(&c, &e, 0.01)).unwrap();
        assert!(!fit.pre_asymptotic.is_empty(), "{fit:?}");
        assert_eq!(fit.pre_asymptotic[0], 0);
        let order = fit.order.unwrap();
        assert!((order.estimate - 1.0).abs() < 0.1, "{fit:?}");
        assert_eq!(fit.local_slopes.len(), 5);
        // Within the Monte Carlo error, nothing is dropped.
        let wide = c.choose(&e, &intervals(&c, &e, 1.0)).unwrap();
        assert!(wide.pre_asymptotic.is_empty());
    }

    #[test]
    fn levels_before_a_zero_crossing_are_pre_asymptotic() {
        // e changes sign between h = 1/8 and 1/16, then follows -h.
        let h: Vec<f64> = (2..7).map(|k| 0.5f64.powi(k)).collect();
        let e = [0.2, 0.05, -h[2], -h[3], -h[4]];
        let c = OrderCandidates::new(&h, |_| true);
        let fit = c.choose(&e, &intervals(&c, &e, 0.01)).unwrap();
        assert_eq!(fit.pre_asymptotic, vec![0, 1]);
        assert_eq!(fit.fitted, vec![2, 3, 4]);
        let order = fit.order.unwrap();
        assert!((order.estimate - 1.0).abs() < 1e-12);
        // Three levels after the change: x = 1/4, the slope may still be log2(3/2) off.
        let off = fit.after_crossing.unwrap();
        assert!((off - 1.5f64.log2()).abs() < 1e-12);
        assert!((order.ci_high - (1.0 + 0.01 + off)).abs() < 1e-12);
        // Two levels after it tell no order.
        let late = [0.2, 0.05, 0.01, -h[3], -h[4]];
        let fit = c.choose(&late, &intervals(&c, &late, 0.01)).unwrap();
        assert_eq!(fit.fitted, vec![3, 4]);
        assert!(fit.order.is_none());
    }

    #[test]
    fn the_true_order_of_the_model_with_a_zero_is_covered() {
        // e = h (1 - 16 h): zero at h0 = 1/16, levels h = 1/4 .. 1/128.
        let h: Vec<f64> = (2..8).map(|k| 0.5f64.powi(k)).collect();
        let e: Vec<f64> = h.iter().map(|h| h * (1.0 - 16.0 * h)).collect();
        let c = OrderCandidates::new(&h, |j| j != 2);
        let fit = c.choose(&e, &intervals(&c, &e, 0.01)).unwrap();
        let order = fit.order.unwrap();
        assert!(order.estimate < 0.8, "{fit:?}");
        assert!(order.contains(1.0), "{fit:?}");
    }

    #[test]
    fn a_slope_still_moving_at_the_finest_levels_widens_the_interval_to_the_true_order() {
        // e = h (1 - 3 h)... with h = 1/8 .. 1/64: local slopes below 1 and rising towards it.
        let h: Vec<f64> = (3..7).map(|k| 0.5f64.powi(k)).collect();
        let e: Vec<f64> = h.iter().map(|h| h * (1.0 - 3.0 * h)).collect();
        let c = OrderCandidates::new(&h, |_| true);
        let fit = c.choose(&e, &intervals(&c, &e, 1e-3)).unwrap();
        let bending = fit.bending.expect("the slopes still change");
        assert!(bending > 0.05, "{fit:?}");
        let order = fit.order.unwrap();
        assert!(order.estimate < 0.95, "{fit:?}");
        assert!(order.contains(1.0), "{fit:?}");
        // A power law does not bend: its interval is the fit's resolution.
        let plain: Vec<f64> = h.iter().map(|h| 0.3 * h).collect();
        let fit = c.choose(&plain, &intervals(&c, &plain, 1e-3)).unwrap();
        assert_eq!(fit.bending, None);
        let order = fit.order.unwrap();
        assert!((order.ci_high - order.ci_low - 2.0 * PRE_ASYMPTOTIC_TOLERANCE).abs() < 1e-12);
    }

    #[test]
    fn slopes_that_grow_apart_tell_no_order() {
        // Local slopes 0.1, 0.4, 1.1, 2.5 (an error switched off by truncation at small h).
        let h: Vec<f64> = (2..7).map(|k| 0.5f64.powi(k)).collect();
        let e = with_local_slopes(&[0.1, 0.4, 1.1, 2.5]);
        let c = OrderCandidates::new(&h, |_| true);
        let fit = c.choose(&e, &intervals(&c, &e, 0.01)).unwrap();
        assert!(fit.unsettled, "{fit:?}");
        assert!(fit.order.is_none());
        // Slopes that settle (changes 0.4, 0.2) do tell one.
        let settling = with_local_slopes(&[0.3, 0.7, 0.9, 1.0]);
        let fit = c
            .choose(&settling, &intervals(&c, &settling, 0.01))
            .unwrap();
        assert!(!fit.unsettled && fit.order.is_some(), "{fit:?}");
    }

    /// Errors with local slopes `slopes` from 1 at h = 1/4.
    fn with_local_slopes(slopes: &[f64]) -> Vec<f64> {
        let mut e = vec![1.0];
        for s in slopes {
            let last = e[e.len() - 1];
            e.push(last / 2f64.powf(*s));
        }
        e
    }

    #[test]
    fn levels_that_cannot_show_the_asymptote_tell_no_order() {
        let h: Vec<f64> = (2..5).map(|k| 0.5f64.powi(k)).collect();
        let c = OrderCandidates::new(&h, |_| true);
        // Local slopes 1.2 and 1.3 (the true order 1 a level further): a change of 0.1 that a
        // Monte Carlo error of 0.2 hides widens the finest slope's interval by its reach, 0.3.
        let e = with_local_slopes(&[1.2, 1.3]);
        let fit = c.choose(&e, &intervals(&c, &e, 0.2)).unwrap();
        assert!(!fit.unshown && fit.bending.is_none(), "{fit:?}");
        let order = fit.order.unwrap();
        assert!(order.contains(1.0), "{order:?}");
        assert!((order.ci_low - (1.3 - 0.2 - 0.3)).abs() < 1e-9, "{order:?}");
        // The same slopes with an error of 1: the change is unknown to within an order.
        let fit = c.choose(&e, &intervals(&c, &e, 1.0)).unwrap();
        assert!(fit.unshown && fit.order.is_none(), "{fit:?}");
        // Two levels have one local slope: nothing to compare it with.
        let two = OrderCandidates::new(&h, |j| j > 0);
        let fit = two.choose(&e, &intervals(&two, &e, 0.01)).unwrap();
        assert_eq!(fit.fitted, vec![1, 2]);
        assert!(fit.unshown && fit.order.is_none(), "{fit:?}");
    }

    #[test]
    fn fewer_than_two_resolved_levels_give_no_order() {
        let h = [0.5, 0.25, 0.125];
        let c = OrderCandidates::new(&h, |j| j == 1);
        assert!(c.is_empty());
        assert!(c.choose(&[1.0, 0.5, 0.25], &[]).is_none());
    }
}
