//! The coefficients of the inherent SDE (seed eq. 2.4) and the multiplier increment (eq. 2.3).
//!
//! Both are the same linear map of a force f applied at (r, v):
//!
//! ```text
//! dmu = -G_M(r)^-1 { Dg(r) M^-1 f + D^2 g(r)(v, v) dt },   dv = M^-1 [f + grad g(r) dmu]
//! ```
//!
//! with f = a(r, v) dt + B(r, v) dw. Since M^-1 [f + grad g G_M^-1 (-Dg M^-1 f)] = M^-1 P_M f,
//! dv is exactly the velocity increment of eq. 2.4 and dmu that of eq. 2.3: P_M is never formed,
//! one factorization of G_M(r) serves the drift, the noise, the multiplier and the velocity
//! projection at r.

use sdae_manifold::{Constraint, Curvature, Factorize, Mass, Solve, scratch_len};
use sdae_model::{System, check_dim, check_dimensions, check_step_input, check_step_size};

use crate::error::{ReferenceError, check_finite};

/// A [`System`] whose constraint has a second derivative ([`Curvature`]) and a Gram storage
/// that can be factored: what the inherent SDE needs. Implemented for every such system.
pub trait CurvedSystem: System<Constraint: Curvature> {}

impl<S> CurvedSystem for S where S: System<Constraint: Curvature> {}

type GramOf<S> = <<S as System>::Constraint as Constraint>::Gram;
type FactorOf<S> = <GramOf<S> as Factorize>::Factor;

/// The inherent SDE of a system (seed eq. 2.4) with the multiplier formula (eq. 2.3), and the
/// buffers to evaluate them without allocating.
///
/// Evaluations at a point r go in two stages: [`InherentSde::prepare`] factors G_M(r), then
/// the `*_prepared` functions reuse the factor. The checked one-shot functions
/// ([`InherentSde::drift`], [`InherentSde::diffusion`], [`InherentSde::multiplier_increment`])
/// do both.
#[derive(Debug, Clone)]
pub struct InherentSde<S: CurvedSystem> {
    system: S,
    gram: GramOf<S>,
    factor: FactorOf<S>,
    scratch: Vec<f64>,
    /// The force f, then M^-1 f.
    force: Vec<f64>,
    /// D^2 g(r)(v, v).
    curvature: Vec<f64>,
    /// The point r of the last successful [`InherentSde::prepare`].
    prepared_at: Vec<f64>,
    prepared: bool,
}

impl<S: CurvedSystem> InherentSde<S> {
    /// Buffers for `system`; fails unless 1 <= m < n and the mass matrix has order n.
    pub fn new(system: S) -> Result<Self, ReferenceError> {
        let (n, m) = check_dimensions(&system)?;
        let gram = system.constraint().new_gram();
        Ok(Self {
            factor: gram.new_factor(),
            gram,
            scratch: vec![0.0; scratch_len(n, m)],
            force: vec![0.0; n],
            curvature: vec![0.0; m],
            prepared_at: vec![0.0; n],
            prepared: false,
            system,
        })
    }

    /// The system.
    pub fn system(&self) -> &S {
        &self.system
    }

    /// n, the dimension of r and v.
    pub fn dim(&self) -> usize {
        self.force.len()
    }

    /// m, the number of constraints (the dimension of mu).
    pub fn n_constraints(&self) -> usize {
        self.curvature.len()
    }

    /// l, the dimension of the Brownian motion.
    pub fn noise_dim(&self) -> usize {
        self.system.noise_dim()
    }

    /// Builds G_M(r) = Dg(r) M^-1 grad g(r) (seed Section 2.1) with
    /// [`Constraint::cross_gram`] and factors it for the evaluations at r that follow.
    #[inline]
    pub fn prepare(&mut self, r: &[f64]) -> Result<(), ReferenceError> {
        check_dim("position r", self.dim(), r.len())?;
        self.prepared = false;
        let c = self.system.constraint();
        c.cross_gram(r, r, self.system.mass(), &mut self.scratch, &mut self.gram);
        self.gram.factor_into(&mut self.factor)?;
        if cfg!(debug_assertions) {
            self.prepared_at.copy_from_slice(r);
        }
        self.prepared = true;
        Ok(())
    }

    /// Debug-time guard: the prepared factor belongs to this r.
    fn assert_prepared(&self, r: &[f64]) {
        debug_assert!(
            self.prepared && self.prepared_at.as_slice() == r,
            "InherentSde: call prepare(r) before the *_prepared evaluations at r"
        );
    }

    /// With `self.force` = f: dmu = -G_M^-1 { Dg M^-1 f + D^2 g(v, v) dt } and
    /// dv = M^-1 [f + grad g dmu] (the common core of eq. 2.3 and eq. 2.4).
    #[inline(always)]
    fn constrain_force(&mut self, r: &[f64], v: &[f64], dt: f64, dv: &mut [f64], dmu: &mut [f64]) {
        let c = self.system.constraint();
        let mass = self.system.mass();
        mass.apply_inverse(&mut self.force);
        c.jacobian_mul(r, &self.force, dmu);
        if dt != 0.0 {
            c.second_derivative(r, v, v, &mut self.curvature);
            for (z, k) in dmu.iter_mut().zip(&self.curvature) {
                *z += dt * k;
            }
        }
        self.factor.solve_in_place(dmu);
        for z in dmu.iter_mut() {
            *z = -*z;
        }
        c.displace(r, dmu, mass, &self.force, dv);
    }

    /// With G_M(r) prepared: the drift of the inherent SDE, seed eq. 2.4 (velocity block of
    /// Lemma 4.2's drift; the position block is v),
    /// `accel = M^-1 [P_M(r) a(r, v) - grad g(r) G_M(r)^-1 D^2 g(r)(v, v)]`, and the drift
    /// part of the multiplier, eq. 2.3:
    /// `mu_rate = -G_M(r)^-1 { Dg(r) M^-1 a(r, v) + D^2 g(r)(v, v) }`.
    #[inline]
    pub fn drift_prepared(&mut self, r: &[f64], v: &[f64], accel: &mut [f64], mu_rate: &mut [f64]) {
        self.assert_prepared(r);
        self.system.drift(r, v, &mut self.force);
        self.constrain_force(r, v, 1.0, accel, mu_rate);
    }

    /// With G_M(r) prepared: the diffusion of the inherent SDE, seed eq. 2.4, applied to an
    /// increment, `dv = M^-1 P_M(r) B(r, v) dw`, and the noise part of the multiplier
    /// increment, eq. 2.3: `dmu = -G_M(r)^-1 Dg(r) M^-1 B(r, v) dw`.
    #[inline]
    pub fn noise_prepared(
        &mut self, r: &[f64], v: &[f64], dw: &[f64], dv: &mut [f64], dmu: &mut [f64],
    ) {
        self.assert_prepared(r);
        self.force.fill(0.0);
        self.system.add_noise(r, v, dw, &mut self.force);
        self.constrain_force(r, v, 0.0, dv, dmu);
    }

    fn check_state_dims(&self, r: &[f64], v: &[f64]) -> Result<(), ReferenceError> {
        check_dim("position r", self.dim(), r.len())?;
        check_dim("velocity v", self.dim(), v.len())?;
        sdae_manifold::check_finite("position r", r)?;
        sdae_manifold::check_finite("velocity v", v)?;
        Ok(())
    }

    /// The velocity drift of the inherent SDE, seed eq. 2.4:
    /// `out = M^-1 [P_M(r) a(r, v) - grad g(r) G_M(r)^-1 D^2 g(r)(v, v)]`
    /// (the position drift is v). Checked and one-shot; `mu_rate` receives the drift of mu
    /// (eq. 2.3), `-G_M^-1 { Dg M^-1 a + D^2 g(v, v) }`.
    pub fn drift(
        &mut self, r: &[f64], v: &[f64], out: &mut [f64], mu_rate: &mut [f64],
    ) -> Result<(), ReferenceError> {
        self.check_state_dims(r, v)?;
        check_dim("drift output", self.dim(), out.len())?;
        check_dim("multiplier output", self.n_constraints(), mu_rate.len())?;
        self.prepare(r)?;
        self.drift_prepared(r, v, out, mu_rate);
        check_finite("inherent drift", out)
    }

    /// The diffusion of the inherent SDE applied to an increment, seed eq. 2.4:
    /// `out = M^-1 P_M(r) B(r, v) dw`, with P_M(r) x = x - grad g G_M^-1 Dg M^-1 x.
    /// Checked and one-shot.
    pub fn diffusion(
        &mut self, r: &[f64], v: &[f64], dw: &[f64], out: &mut [f64],
    ) -> Result<(), ReferenceError> {
        self.check_state_dims(r, v)?;
        check_dim("Brownian increment dw", self.noise_dim(), dw.len())?;
        check_dim("diffusion output", self.dim(), out.len())?;
        self.prepare(r)?;
        let mut work = std::mem::take(&mut self.curvature);
        self.noise_prepared(r, v, dw, out, &mut work);
        self.curvature = work;
        check_finite("inherent diffusion", out)
    }

    /// The multiplier increment over a step h, seed eq. 2.3:
    /// `out = -G_M(r)^-1 { Dg(r) M^-1 [a(r, v) h + B(r, v) dw] + D^2 g(r)(v, v) h }`.
    /// Checked and one-shot; `dv` receives the matching Euler-Maruyama velocity increment of
    /// eq. 2.4, `M^-1 [a h + B dw + grad g(r) out]`.
    pub fn multiplier_increment(
        &mut self, r: &[f64], v: &[f64], h: f64, dw: &[f64], dv: &mut [f64], out: &mut [f64],
    ) -> Result<(), ReferenceError> {
        self.check_state_dims(r, v)?;
        check_step_size(h)?;
        check_dim("Brownian increment dw", self.noise_dim(), dw.len())?;
        check_dim("velocity increment output", self.dim(), dv.len())?;
        check_dim("multiplier output", self.n_constraints(), out.len())?;
        self.prepare(r)?;
        self.system.drift(r, v, &mut self.force);
        for f in self.force.iter_mut() {
            *f *= h;
        }
        self.system.add_noise(r, v, dw, &mut self.force);
        self.constrain_force(r, v, h, dv, out);
        check_finite("multiplier increment", out)
    }

    /// Checks a step's inputs: lengths of r, v, dw, finiteness of r and v, and h.
    pub(crate) fn check_step_input(
        &self, r: &[f64], v: &[f64], h: f64, dw: &[f64],
    ) -> Result<(), ReferenceError> {
        check_step_input(&self.system, r, v, h, dw)?;
        sdae_manifold::check_finite("position r", r)?;
        sdae_manifold::check_finite("velocity v", v)?;
        Ok(())
    }
}
