//! The functions of the grammar and their evaluation over any [`Real`].

use sdae_lanes::Real;

/// A function of one argument of the grammar.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Func {
    /// Sine.
    Sin,
    /// Cosine.
    Cos,
    /// Tangent.
    Tan,
    /// The exponential.
    Exp,
    /// The natural logarithm.
    Log,
    /// The square root.
    Sqrt,
    /// The absolute value.
    Abs,
    /// The hyperbolic tangent.
    Tanh,
    /// The sign: 1 above zero, -1 below, 0 at zero (of either sign), NaN at NaN (the
    /// derivative of `abs`).
    Sign,
}

/// The names of the grammar's functions, in the order of the crate docs (`atan2` takes two
/// arguments, the others one).
pub const FUNCTIONS: [&str; 10] = [
    "sin", "cos", "tan", "exp", "log", "sqrt", "abs", "atan2", "tanh", "sign",
];

/// The names of the grammar's constants and their values.
pub const CONSTANTS: [(&str, f64); 1] = [("pi", std::f64::consts::PI)];

impl Func {
    /// Every function of one argument.
    pub const ALL: [Func; 9] = [
        Func::Sin,
        Func::Cos,
        Func::Tan,
        Func::Exp,
        Func::Log,
        Func::Sqrt,
        Func::Abs,
        Func::Tanh,
        Func::Sign,
    ];

    /// Its name in the grammar.
    pub fn name(self) -> &'static str {
        match self {
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tan => "tan",
            Func::Exp => "exp",
            Func::Log => "log",
            Func::Sqrt => "sqrt",
            Func::Abs => "abs",
            Func::Tanh => "tanh",
            Func::Sign => "sign",
        }
    }

    /// The function of that name.
    pub fn from_name(name: &str) -> Option<Func> {
        Func::ALL.into_iter().find(|f| f.name() == name)
    }

    /// Its value at `x`: the square root and the absolute value as the number type's own
    /// (correctly rounded, lane for lane), the others path by path with the standard library's
    /// f64 function ([`Real::map_each`]), so that every lane computes what `f64` computes.
    #[inline(always)]
    pub fn apply<T: Real>(self, x: T) -> T {
        match self {
            Func::Sqrt => x.sqrt(),
            Func::Abs => x.abs(),
            Func::Sin => x.map_each(f64::sin),
            Func::Cos => x.map_each(f64::cos),
            Func::Tan => x.map_each(f64::tan),
            Func::Exp => x.map_each(f64::exp),
            Func::Log => x.map_each(f64::ln),
            Func::Tanh => x.map_each(f64::tanh),
            Func::Sign => x.map_each(sign),
        }
    }
}

/// 1 above zero, -1 below, 0 at either zero, NaN at NaN.
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        x * 0.0
    }
}

/// The arc tangent of y / x in the quadrant of (x, y), path by path (`f64::atan2`).
#[inline(always)]
pub fn atan2<T: Real>(y: T, x: T) -> T {
    y.zip_map_each(x, f64::atan2)
}

/// x^y for a real exponent, path by path (`f64::powf`).
#[inline(always)]
pub fn powf<T: Real>(x: T, y: T) -> T {
    x.zip_map_each(y, f64::powf)
}

/// The largest |n| of an integer power x^n computed by multiplications ([`powi`]); beyond it,
/// and for exponents that are not integers, x^y is `f64::powf`.
pub const MAX_INTEGER_POWER: i32 = 64;

/// x^n by multiplications, the same sequence on every number type so that lanes and f64 agree
/// bit for bit: from the highest bit of |n| down, square, then multiply by x where the bit is
/// set (x^2 = x x, x^3 = (x x) x, x^4 = (x x)(x x)); x^0 = 1; for n < 0, 1 / x^|n|.
#[inline(always)]
pub fn powi<T: Real>(x: T, n: i32) -> T {
    let m = n.unsigned_abs();
    if m == 0 {
        return x.splat_like(1.0);
    }
    let mut result = x;
    for bit in (0..31 - m.leading_zeros()).rev() {
        result = result * result;
        if (m >> bit) & 1 == 1 {
            result = result * x;
        }
    }
    if n < 0 {
        x.splat_like(1.0) / result
    } else {
        result
    }
}

/// The steps of [`powi`] for |n| = m: for each bit below the highest, whether it multiplies by
/// x after squaring (what a compiled program expands x^n into).
pub(crate) fn powi_steps(m: u32) -> impl Iterator<Item = bool> {
    (0..31u32.saturating_sub(m.leading_zeros()))
        .rev()
        .map(move |bit| (m >> bit) & 1 == 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_powers_are_repeated_products() {
        let x = 1.1f64;
        assert_eq!(powi(x, 0), 1.0);
        assert_eq!(powi(x, 1), x);
        assert_eq!(powi(x, 2), x * x);
        assert_eq!(powi(x, 3), x * x * x);
        assert_eq!(powi(x, 4), (x * x) * (x * x));
        assert_eq!(powi(x, 5), (x * x) * (x * x) * x);
        assert_eq!(powi(x, -2), 1.0 / (x * x));
        assert_eq!(powi_steps(5).collect::<Vec<_>>(), [false, true]);
        assert_eq!(powi_steps(1).count(), 0);
        assert!(sign(f64::NAN).is_nan());
        assert_eq!(sign(-0.0), 0.0);
    }
}
