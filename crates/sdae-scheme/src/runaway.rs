//! When truncated steps keep a rotor's energy bounded (beyond the seed).
//!
//! A point of mass m on a circle of radius L with speed s under linear friction a = -gamma v.
//! One step of eq. 3.1 from r = L e1, v = s e2 moves to y = r + eta h s e2 and back onto the
//! circle along e1, so with d = eta h s the velocity's correction lambda e1 from
//! Dg(r') v' = 0 gives |v'|^2 = |v~|^2 L^2 / (L^2 - d^2): the explicit rotation multiplies the
//! kinetic energy by 1 / (1 - theta^2), theta = d / L, while the friction multiplies it by
//! (1 - eta h gamma / m)^2. A truncated step at high speed (|v|^2 h > C_eta, |v| >= gamma / m)
//! has eta h = C_eta / s^2 and theta = C_eta / (s L), so the energy grows iff
//!
//! ```text
//! (1 - gamma C_eta / (m s^2))^2 > 1 - C_eta^2 / (s^2 L^2)
//!   <=>  C_eta (1 / L^2 + gamma^2 / (m^2 s^2)) > 2 gamma / m,
//! ```
//!
//! and as s grows this tends to C_eta > 2 gamma L^2 / m: both the gain and the loss per step
//! scale as 1/s^2, so truncation slows the runaway but stops it only below this bound. Noise,
//! which truncation does not damp, only adds energy. For a system of several rotors (a molecule
//! with rigid bonds) the bound of its shortest bond and lightest atom is the safe one, since
//! eta is computed from all velocities together and one bond may carry most of them.

/// The largest C_eta for which truncated steps keep a rotor's kinetic energy bounded:
/// 2 gamma L^2 / m for friction coefficient `friction` (a = -gamma v), radius `length` and
/// `mass` (see the module's documentation). 0 without friction: any truncation then lets a
/// fast rotor gain energy.
pub fn runaway_bound(friction: f64, length: f64, mass: f64) -> f64 {
    2.0 * friction * length * length / mass
}
