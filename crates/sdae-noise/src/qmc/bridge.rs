//! The Brownian-bridge construction of a path from standard normals ([`BrownianBridge`]).

use std::collections::VecDeque;

use sdae_lanes::Real;

use crate::error::NoiseError;

/// The Brownian-bridge construction of a standard Brownian path W on the grid t_n = n,
/// n = 0..N (unit steps; scale by sqrt(h) for steps of size h), from N standard normals z_k
/// taken in construction order: first W(N) = sqrt(N) z_0, then, breadth first, the midpoint
/// m = floor((l + r) / 2) of each interval (l, r) of known nodes with r - l >= 2,
///
/// ```text
/// W(m) = ((r - m) W(l) + (m - l) W(r)) / (r - l) + sqrt((m - l)(r - m) / (r - l)) z_k,
/// ```
///
/// the mean and standard deviation of W(m) given W(l) and W(r). After 2^k normals every
/// interval of level k is halved, so the first normals carry the coarse shape of the path. N
/// need not be a power of two.
///
/// ```
/// use sdae_noise::BrownianBridge;
/// let bridge = BrownianBridge::new(4)?;
/// assert_eq!(bridge.construction_order().collect::<Vec<_>>(), [4, 2, 1, 3]);
/// let mut w = [0.0; 5];
/// bridge.fill_path(&[1.0, 0.0, 0.0, 0.0], &mut w);
/// assert_eq!(w, [0.0, 0.5, 1.0, 1.5, 2.0]);
/// # Ok::<(), sdae_noise::NoiseError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct BrownianBridge {
    nodes: Vec<BridgeNode>,
}

/// One step of the construction: W(node) = left_weight W(left) + right_weight W(right) + sd z.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BridgeNode {
    node: usize,
    left: usize,
    right: usize,
    left_weight: f64,
    right_weight: f64,
    sd: f64,
}

impl BrownianBridge {
    /// The construction over `steps` = N >= 1 unit steps.
    pub fn new(steps: usize) -> Result<Self, NoiseError> {
        if steps == 0 {
            return Err(NoiseError::InvalidSetting {
                name: "steps",
                value: 0.0,
                reason: "a Brownian bridge needs at least one step",
            });
        }
        let mut nodes = Vec::with_capacity(steps);
        nodes.push(BridgeNode {
            node: steps,
            left: 0,
            right: 0,
            left_weight: 0.0,
            right_weight: 0.0,
            sd: (steps as f64).sqrt(),
        });
        let mut intervals = VecDeque::from([(0, steps)]);
        while let Some((left, right)) = intervals.pop_front() {
            if right - left >= 2 {
                let mid = (left + right) / 2;
                nodes.push(midpoint(left, mid, right));
                intervals.extend([(left, mid), (mid, right)]);
            }
        }
        Ok(Self { nodes })
    }

    /// The number N of steps.
    pub fn steps(&self) -> usize {
        self.nodes.len()
    }

    /// The grid nodes n in the order the construction fixes W(n): normal k sets the k-th.
    pub fn construction_order(&self) -> impl Iterator<Item = usize> + '_ {
        self.nodes.iter().map(|b| b.node)
    }

    /// `w[n]` = W(n), n = 0..=N, from the normals `z` in construction order (`w[0]` = 0).
    /// Panics unless z has length N and w length N + 1.
    pub fn fill_path(&self, z: &[f64], w: &mut [f64]) {
        let steps = self.steps();
        assert!(
            z.len() == steps && w.len() == steps + 1,
            "a bridge over {steps} steps takes {steps} normals and fills {} nodes",
            steps + 1
        );
        self.fill_strided(z, 0, 1, w);
    }

    /// `w[n]` = W(n), n = 0..=N, of one path (`f64`) or of W paths at once
    /// ([`Lanes`](sdae_lanes::Lanes)), from the normals `normals[offset + k * step]` in
    /// construction order: [`BrownianBridge::fill_path`] of the normals taken with a step, the
    /// same operations in the same order, so that lane i is bit for bit the path of lane i's
    /// normals. The caller checks the lengths (w: N + 1, normals: enough for N with the step).
    #[inline(always)]
    pub(crate) fn fill_strided<T: Real>(
        &self, normals: &[T], offset: usize, step: usize, w: &mut [T],
    ) {
        let Some(first) = normals.get(offset) else {
            return;
        };
        w[0] = first.splat_like(0.0);
        for (k, b) in self.nodes.iter().enumerate() {
            let zk = normals[offset + k * step];
            w[b.node] = w[b.left] * b.left_weight + w[b.right] * b.right_weight + zk * b.sd;
        }
    }
}

/// The step that fixes W(mid) from W(left) and W(right) (the formula of [`BrownianBridge`]).
fn midpoint(left: usize, mid: usize, right: usize) -> BridgeNode {
    let (a, b, span) = (
        (mid - left) as f64,
        (right - mid) as f64,
        (right - left) as f64,
    );
    BridgeNode {
        node: mid,
        left,
        right,
        left_weight: b / span,
        right_weight: a / span,
        sd: (a * b / span).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The normals that give the path w: z_k = (W(n) - mean) / sd, the bridge run backwards.
    fn normals_of(bridge: &BrownianBridge, w: &[f64]) -> Vec<f64> {
        bridge
            .nodes
            .iter()
            .map(|b| (w[b.node] - b.left_weight * w[b.left] - b.right_weight * w[b.right]) / b.sd)
            .collect()
    }

    #[test]
    fn the_order_halves_each_level_and_covers_every_node() {
        let bridge = BrownianBridge::new(8).unwrap();
        let order: Vec<_> = bridge.construction_order().collect();
        assert_eq!(order, [8, 4, 2, 6, 1, 3, 5, 7]);
        for steps in [1, 2, 3, 5, 6, 7, 100, 1000] {
            let mut order: Vec<_> = BrownianBridge::new(steps)
                .unwrap()
                .construction_order()
                .collect();
            order.sort_unstable();
            assert_eq!(order, (1..=steps).collect::<Vec<_>>(), "{steps} steps");
        }
        let order: Vec<_> = BrownianBridge::new(5)
            .unwrap()
            .construction_order()
            .collect();
        assert_eq!(order, [5, 2, 1, 3, 4]);
        assert!(BrownianBridge::new(0).is_err());
    }

    #[test]
    fn the_bridge_rebuilds_a_known_path() {
        for steps in [1, 7, 64, 100] {
            let bridge = BrownianBridge::new(steps).unwrap();
            // Any path: W(n) = sin(n) + n / 3.
            let w: Vec<f64> = (0..=steps)
                .map(|n| {
                    if n == 0 {
                        0.0
                    } else {
                        (n as f64).sin() + n as f64 / 3.0
                    }
                })
                .collect();
            let z = normals_of(&bridge, &w);
            let mut rebuilt = vec![f64::NAN; steps + 1];
            bridge.fill_path(&z, &mut rebuilt);
            for (a, b) in rebuilt.iter().zip(&w) {
                assert!((a - b).abs() < 1e-12, "{steps} steps: {a} vs {b}");
            }
            assert_eq!(z[0], w[steps] / (steps as f64).sqrt());
        }
    }

    #[test]
    fn the_covariance_of_the_nodes_is_that_of_brownian_motion() {
        // W(n) is linear in z: W = L z, and L L^T must be min(n, n'), exactly.
        let steps = 11;
        let bridge = BrownianBridge::new(steps).unwrap();
        let mut columns = Vec::new();
        for k in 0..steps {
            let mut z = vec![0.0; steps];
            z[k] = 1.0;
            let mut w = vec![0.0; steps + 1];
            bridge.fill_path(&z, &mut w);
            columns.push(w);
        }
        for n in 1..=steps {
            for m in 1..=steps {
                let cov: f64 = columns.iter().map(|w| w[n] * w[m]).sum();
                assert!((cov - n.min(m) as f64).abs() < 1e-12, "({n}, {m}): {cov}");
            }
        }
    }
}
