//! The Euler-type solvers of the inherent SDE (seed eq. 2.4, multiplier eq. 2.3) for a sphere
//! constraint with a diagonal mass, W paths at once ([`LaneScheme`]): Euler-Maruyama, its
//! drift-truncated form (Remark 3.3), projected Euler-Maruyama (the projection's root in closed
//! form, [`SphereRoot`]) and stochastic Heun, each with the scalar solver's
//! floating-point operations in the same order, so that a lane computes exactly what the
//! solver computes for that path alone. A lane whose step the formulas do not decide (a
//! singular or non-finite Gram value, a non-finite result) finishes its step through the
//! scalar solver, which reports the failure as for one path.
//!
//! For the sphere g(r) = (1 - |r|^2 / rho^2) / 2 every piece of [`InherentSde`]'s linear map
//! is a closed form: Dg(r) u = -r.u / rho^2, D^2 g(r)(v, v) = -|v|^2 / rho^2,
//! G_M(r) = r^T M^-1 r / rho^4 and M^-1 grad g(r) z = -z M^-1 r / rho^2.
//!
//! [`InherentSde`]: crate::InherentSde

use pulp::Simd;
use sdae_ift::SolverSettings;
use sdae_lanes::{LaneMask, LaneWidth, Lanes};
use sdae_manifold::{Mass, Sphere};
use sdae_model::engine::{
    LaneKernel, LanePaths, LaneRecord, LaneStep, SphereKernels, SphereRoot, StepInput,
    step_sphere_lanes,
};
use sdae_model::{LaneScheme, Scheme, System};

use crate::euler::EulerMaruyama;
use crate::heun::StochasticHeun;
use crate::inherent::CurvedSystem;
use crate::projected::ProjectedEulerMaruyama;
use crate::truncated::TruncatedEulerMaruyama;
use crate::updates;

/// Which solver's step the lanes take.
#[derive(Debug, Clone, Copy)]
enum Method {
    /// Euler-Maruyama ([`EulerMaruyama`]).
    Euler,
    /// Truncated Euler-Maruyama with truncation scale c ([`TruncatedEulerMaruyama`]).
    Truncated(f64),
    /// Stochastic Heun ([`StochasticHeun`]).
    Heun,
    /// Projected Euler-Maruyama with the projection's root-solver settings
    /// ([`ProjectedEulerMaruyama`]).
    Projected(SolverSettings),
}

impl<S: CurvedSystem> LaneScheme for EulerMaruyama<S> {
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool {
        step_lanes(self, Method::Euler, paths, width, StepInput { h, dw })
    }
}

impl<S: CurvedSystem> LaneScheme for TruncatedEulerMaruyama<S> {
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool {
        let method = Method::Truncated(self.scale());
        step_lanes(self, method, paths, width, StepInput { h, dw })
    }
}

impl<S: CurvedSystem> LaneScheme for ProjectedEulerMaruyama<S> {
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool {
        let method = Method::Projected(*self.projection_settings());
        step_lanes(self, method, paths, width, StepInput { h, dw })
    }
}

impl<S: CurvedSystem> LaneScheme for StochasticHeun<S> {
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool {
        step_lanes(self, Method::Heun, paths, width, StepInput { h, dw })
    }
}

/// The lanes' step of `method` where the system is a sphere of dimension <= 3 with a diagonal
/// mass and at most as many noise components ([`step_sphere_lanes`]); `false` otherwise.
fn step_lanes<Sch: Scheme>(
    scheme: &mut Sch, method: Method, paths: &mut LanePaths, width: LaneWidth, input: StepInput<'_>,
) -> bool {
    step_sphere_lanes(scheme, Kernels(method), paths, width, input)
}

/// The solvers' kernels on a sphere ([`SphereKernels`]) for `method`.
struct Kernels(Method);

impl<Sch: Scheme> SphereKernels<Sch> for Kernels {
    type Kernel<const N: usize> = Kernel<N>;
    #[inline(always)]
    fn kernel<const N: usize>(&self, scheme: &Sch, sphere: &Sphere, h: f64) -> Option<Kernel<N>> {
        let method = self.0;
        let sde = SphereSde::<N>::new(scheme.system(), sphere);
        let projection = match method {
            Method::Projected(settings) => Some(SphereRoot::new(
                sphere,
                sde.inverse_mass,
                &settings,
                f64::INFINITY,
            )),
            _ => None,
        };
        Some(Kernel {
            sde,
            method,
            projection,
            h,
        })
    }
}

/// A solver's step of W lanes.
struct Kernel<const N: usize> {
    sde: SphereSde<N>,
    method: Method,
    /// The projection onto the sphere (an unbounded ball) of projected Euler-Maruyama.
    projection: Option<SphereRoot<N>>,
    h: f64,
}

impl<Sch: Scheme, const N: usize> LaneKernel<Sch, N> for Kernel<N> {
    #[inline(always)]
    fn step<Sd: Simd>(
        &self, scheme: &Sch, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<LaneStep<Sd, N>> {
        let (system, h) = (scheme.system(), self.h);
        match self.method {
            Method::Euler => self.sde.euler(system, r, v, h, dw, None),
            Method::Truncated(scale) => self.sde.euler(system, r, v, h, dw, Some(scale)),
            Method::Heun => self.sde.heun(system, r, v, h, dw),
            Method::Projected(_) => {
                let step = self.sde.euler(system, r, v, h, dw, None)?;
                self.projection.map(|root| self.sde.project(&root, step))
            }
        }
    }
}

/// The sphere and the diagonal of M^-1.
struct SphereSde<const N: usize> {
    sphere: Sphere,
    inverse_mass: [f64; N],
}

/// `EulerParts` over W lanes: the coefficients of one Euler step at (r, v), and the lanes
/// where they are defined and finite.
struct Parts<Sd: Simd, const N: usize> {
    ok: LaneMask<Sd>,
    /// Velocity drift of eq. 2.4.
    accel: [Lanes<Sd>; N],
    /// Drift of mu, eq. 2.3.
    mu_rate: Lanes<Sd>,
    /// M^-1 P_M B dw.
    noise_v: [Lanes<Sd>; N],
    /// -G_M^-1 Dg M^-1 B dw.
    noise_mu: Lanes<Sd>,
}

impl<const N: usize> SphereSde<N> {
    fn new<S: System>(system: &S, sphere: &Sphere) -> Self {
        let mass = system.mass();
        Self {
            sphere: *sphere,
            inverse_mass: std::array::from_fn(|k| mass.inverse_diagonal_entry(k).unwrap_or(0.0)),
        }
    }

    /// `InherentSde::constrain_force` with the factor 1 / G_M(r) (`inverse_gram`) and the
    /// force f: returns dv = M^-1 [f + grad g dmu] and dmu = -G_M^-1 { Dg M^-1 f + D^2 g(v, v) }
    /// (the curvature term only with `curvature`, which is the drift's dt = 1).
    #[inline(always)]
    fn constrain<Sd: Simd>(
        &self, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], inverse_gram: Lanes<Sd>,
        mut force: [Lanes<Sd>; N], curvature: bool,
    ) -> ([Lanes<Sd>; N], Lanes<Sd>) {
        for (f, w) in force.iter_mut().zip(self.inverse_mass) {
            *f = *f * w;
        }
        let mut dmu = self.sphere.normal_rate(r, &force);
        if curvature {
            dmu = dmu + self.sphere.curvature_rate(v, v) * 1.0;
        }
        let dmu = -(dmu * inverse_gram);
        let mut dv = force;
        self.sphere
            .displace_diagonal(r, dmu, |k| self.inverse_mass[k], &force, &mut dv);
        (dv, dmu)
    }

    /// `EulerParts::evaluate` at (r, v) (with the noise parts for l > 0 increments); `None` if
    /// the system has no lane form.
    #[inline(always)]
    fn parts<S: System, Sd: Simd>(
        &self, system: &S, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<Parts<Sd, N>> {
        let zero = r[0].splat_like(0.0);
        // G_M(r) = r^T M^-1 r / rho^4, factored as 1 / G_M(r) where finite and nonzero.
        let gram = self.gram(r);
        let mut ok = gram.is_finite().and(!gram.eq(zero));
        let inverse_gram = zero.splat_like(1.0) / gram;
        let mut force = [zero; N];
        if !system.drift_lanes(r, v, &mut force) {
            return None;
        }
        let (accel, mu_rate) = self.constrain(r, v, inverse_gram, force, true);
        ok = ok.and(all_finite(&accel));
        let (mut noise_v, mut noise_mu) = ([zero; N], zero);
        if !dw.is_empty() {
            let mut force = [zero; N];
            if !system.add_noise_lanes(r, v, dw, &mut force) {
                return None;
            }
            (noise_v, noise_mu) = self.constrain(r, v, inverse_gram, force, false);
            ok = ok.and(all_finite(&noise_v));
        }
        Some(Parts {
            ok,
            accel,
            mu_rate,
            noise_v,
            noise_mu,
        })
    }

    /// One (truncated, with `Some(c)`) Euler-Maruyama step, `EulerCore::propose`: theta =
    /// min(1, c / (|f| h)) with |f|^2 = |v|^2 + |accel|^2, r' = r + theta h v,
    /// v' = v + theta h accel + noise_v, dmu = theta h mu_rate + noise_mu.
    #[inline(always)]
    fn euler<S: System, Sd: Simd>(
        &self, system: &S, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], h: f64, dw: &[Lanes<Sd>],
        scale: Option<f64>,
    ) -> Option<LaneStep<Sd, N>> {
        let parts = self.parts(system, r, v, dw)?;
        Some(Self::euler_with(&parts, r, v, h, scale))
    }

    /// [`SphereSde::euler`] with the parts at (r, v) evaluated.
    #[inline(always)]
    fn euler_with<Sd: Simd>(
        parts: &Parts<Sd, N>, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], h: f64, scale: Option<f64>,
    ) -> LaneStep<Sd, N> {
        let theta = match scale {
            None => r[0].splat_like(1.0),
            Some(c) => updates::truncation(c, h, updates::drift_norm(v, &parts.accel)),
        };
        let dt = theta * h;
        let (mut next_r, mut next_v) = (*r, *v);
        for i in 0..N {
            next_r[i] = updates::euler_position(r[i], v[i], dt);
            next_v[i] = updates::euler_velocity(v[i], parts.accel[i], parts.noise_v[i], dt);
        }
        let dmu = updates::euler_multiplier(parts.mu_rate, parts.noise_mu, dt);
        let ok = parts
            .ok
            .and(all_finite(&next_v))
            .and(all_finite(&next_r))
            .and(dmu.is_finite());
        // A plain step, with the truncation factor theta where truncated (`StepOutcome::eta`).
        LaneStep {
            ok,
            r: next_r,
            v: next_v,
            dmu,
            record: LaneRecord::plain(theta),
        }
    }

    /// One stochastic Heun step (`StochasticHeun`): the Euler-Maruyama predictor X~, then
    /// r' = r + h/2 (v + v~), v' = v + h/2 (accel + accel~) + noise_v,
    /// dmu = h/2 (mu_rate + mu_rate~) + noise_mu.
    #[inline(always)]
    fn heun<S: System, Sd: Simd>(
        &self, system: &S, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], h: f64, dw: &[Lanes<Sd>],
    ) -> Option<LaneStep<Sd, N>> {
        let parts = self.parts(system, r, v, dw)?;
        let predictor = Self::euler_with(&parts, r, v, h, None);
        let at_predictor = self.parts(system, &predictor.r, &predictor.v, &[])?;
        let half = r[0].splat_like(0.5 * h);
        let (mut next_r, mut next_v) = (*r, *v);
        for i in 0..N {
            next_r[i] = updates::heun_position(r[i], v[i], predictor.v[i], half);
            next_v[i] = updates::heun_velocity(
                v[i],
                parts.accel[i],
                at_predictor.accel[i],
                parts.noise_v[i],
                half,
            );
        }
        let dmu =
            updates::heun_multiplier(parts.mu_rate, at_predictor.mu_rate, parts.noise_mu, half);
        let ok = predictor
            .ok
            .and(at_predictor.ok)
            .and(all_finite(&next_v))
            .and(all_finite(&next_r))
            .and(dmu.is_finite());
        Some(LaneStep {
            ok,
            r: next_r,
            v: next_v,
            dmu,
            record: LaneRecord::plain(r[0].splat_like(1.0)),
        })
    }
}

impl<const N: usize> SphereSde<N> {
    /// G_M(r) = r^T M^-1 r / rho^4 ([`Sphere::value_and_gram`] at x = r).
    #[inline(always)]
    fn gram<Sd: Simd>(&self, r: &[Lanes<Sd>; N]) -> Lanes<Sd> {
        let [_, gram] = self.sphere.value_and_gram(r, r, |k| self.inverse_mass[k]);
        gram
    }

    /// `ProjectedEulerMaruyama::project_proposal` of an Euler-Maruyama step to (y, u): r' = the
    /// root's point of the projection of y along its normal (`root`, with r = y; y itself
    /// where gamma = 0), then v' = u - M^-1 grad g(r') G_M(r')^-1 Dg(r') u.
    #[inline(always)]
    fn project<Sd: Simd>(&self, root: &SphereRoot<N>, step: LaneStep<Sd, N>) -> LaneStep<Sd, N> {
        let (y, u) = (step.r, step.v);
        let position = root.solve(&y, &y);
        let zero = y[0].splat_like(0.0);
        let at_y = position.gamma.eq(zero);
        let r: [Lanes<Sd>; N] = std::array::from_fn(|i| Lanes::select(at_y, y[i], position.x[i]));
        // G_M(r') = r'^T M^-1 r' / rho^4, lambda = G_M^-1 Dg(r') u, then
        // v' = u + M^-1 grad g(r') (-lambda).
        let gram = self.gram(&r);
        let lambda = self.sphere.normal_rate(&r, &u) * (zero.splat_like(1.0) / gram);
        let mut v = u;
        self.sphere
            .displace_diagonal(&r, -lambda, |k| self.inverse_mass[k], &u, &mut v);
        let ok = step
            .ok
            .and(position.ok)
            .and(all_finite(&r))
            .and(gram.is_finite())
            .and(!gram.eq(zero))
            .and(all_finite(&v));
        LaneStep { ok, r, v, ..step }
    }
}

/// The lanes where every coordinate is finite.
#[inline(always)]
fn all_finite<Sd: Simd, const N: usize>(x: &[Lanes<Sd>; N]) -> LaneMask<Sd> {
    let mut ok = x[0].is_finite();
    for xi in &x[1..] {
        ok = ok.and(xi.is_finite());
    }
    ok
}
