//! The 1 x 1 Newton matrix of a constraint with one equation (m = 1) over W lanes, and its
//! factorization: the operations of [`ScalarGram`](crate::ScalarGram) and
//! [`ScalarFactor`](crate::ScalarFactor) lane by lane (the product, and b / A as b (1 / A)).

use pulp::Simd;
use sdae_lanes::{LaneMask, Lanes};

use super::{FactorLanes, MatrixLanes, RightHandSide};

/// The number Dg(x) M^-1 grad g(r) in each lane (for m = 1).
#[derive(Debug, Clone, Copy)]
pub struct ScalarLanes<Sd: Simd>(pub Lanes<Sd>);

/// 1 / A of a [`ScalarLanes`] A, as `ScalarFactor` forms it.
#[derive(Debug, Clone, Copy)]
pub struct ReciprocalLanes<Sd: Simd>(Lanes<Sd>);

impl<Sd: Simd> MatrixLanes<Sd> for ScalarLanes<Sd> {
    fn zeros(simd: Sd, _m: usize) -> Self {
        Self(Lanes::splat(simd, 0.0))
    }

    /// out = A x.
    #[inline(always)]
    fn mul_vec(&self, x: &[Lanes<Sd>], out: &mut [Lanes<Sd>]) {
        out[0] = self.0 * x[0];
    }
}

impl<Sd: Simd> FactorLanes<Sd> for ReciprocalLanes<Sd> {
    type Matrix = ScalarLanes<Sd>;

    fn zeros(simd: Sd, _m: usize) -> Self {
        Self(Lanes::splat(simd, 0.0))
    }

    /// 1 / A, and with `rhs` = (b, out) the whole solve out = b (1 / A); the lanes where A is
    /// finite and not zero (those `ScalarFactor` accepts).
    #[inline(always)]
    fn factor(&mut self, a: &ScalarLanes<Sd>, rhs: RightHandSide<'_, Sd>) -> LaneMask<Sd> {
        let a = a.0;
        self.0 = a.splat_like(1.0) / a;
        if let Some((b, out)) = rhs {
            out[0] = b[0] * self.0;
        }
        a.is_finite().and(!a.eq(a.splat_like(0.0)))
    }

    /// b <- b (1 / A): the whole solve.
    #[inline(always)]
    fn forward_in_place(&self, b: &mut [Lanes<Sd>]) {
        b[0] = b[0] * self.0;
    }

    /// Nothing left after [`FactorLanes::forward_in_place`].
    #[inline(always)]
    fn back_substitute(&self, _out: &mut [Lanes<Sd>]) {}
}
