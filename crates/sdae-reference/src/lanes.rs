//! The Euler-type solvers of the inherent SDE (seed eq. 2.4, multiplier eq. 2.3) for a sphere
//! constraint with a diagonal mass, W paths at once ([`LaneScheme`]): Euler-Maruyama, its
//! drift-truncated form (Remark 3.3), projected Euler-Maruyama (the projection's root in closed
//! form, [`SphereRoot`]) and stochastic Heun. Each runs the step its solver runs for one path
//! (`euler_step`, `heun_step`, `projected_step`, written once over [`Real`]) with the
//! lanes' [`InherentKernel`] ([`SphereLanes`]), so that a lane computes exactly what the
//! solver computes for that path alone. A lane whose step the formulas do not decide (a
//! singular or non-finite Gram value, a non-finite result) finishes its step through the
//! scalar solver, which reports the failure as for one path.
//!
//! For the sphere g(r) = (1 - |r|^2 / rho^2) / 2 every piece of [`InherentSde`]'s linear map
//! is a closed form: Dg(r) u = -r.u / rho^2, D^2 g(r)(v, v) = -|v|^2 / rho^2,
//! G_M(r) = r^T M^-1 r / rho^4 and M^-1 grad g(r) z = -z M^-1 r / rho^2.
//!
//! [`InherentSde`]: crate::InherentSde
//! [`Real`]: sdae_lanes::Real

use pulp::Simd;
use sdae_ift::SolverSettings;
use sdae_lanes::{LaneMask, LaneWidth, Lanes};
use sdae_manifold::{Equations, Mass};
use sdae_model::engine::{
    LaneKernel, LanePaths, LaneRecord, LaneStep, SphereKernels, SphereRoot, StepInput,
    step_sphere_lanes,
};
use sdae_model::{KernelState, LaneScheme, Scheme, System};

use crate::euler::{EulerMaruyama, euler_step};
use crate::heun::{StochasticHeun, heun_step};
use crate::inherent::CurvedSystem;
use crate::kernel::{EulerParts, InherentKernel, Next, Parts, Projecting, ProjectionKernel};
use crate::projected::{ProjectedEulerMaruyama, projected_step};
use crate::truncated::TruncatedEulerMaruyama;

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
    type Kernel<E: Equations, const N: usize> = Kernel<E, N>;
    #[inline(always)]
    fn kernel<E: Equations, const N: usize>(
        &self, scheme: &Sch, constraint: &E, h: f64,
    ) -> Option<Kernel<E, N>> {
        let method = self.0;
        let sde = SphereSde::<E, N>::new(scheme.system(), constraint);
        let projection = match method {
            Method::Projected(settings) => Some(SphereRoot::new(
                constraint,
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
struct Kernel<E, const N: usize> {
    sde: SphereSde<E, N>,
    method: Method,
    /// The projection onto the sphere (an unbounded ball) of projected Euler-Maruyama.
    projection: Option<SphereRoot<E, N>>,
    h: f64,
}

impl<Sch: Scheme, E: Equations, const N: usize> LaneKernel<Sch, N> for Kernel<E, N> {
    /// The solver's step body over W lanes with the sphere's [`SphereLanes`] kernel.
    #[inline(always)]
    fn step<Sd: Simd>(
        &self, scheme: &Sch, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<LaneStep<Sd, N>> {
        let zero = r[0].splat_like(0.0);
        let mut kernel = SphereLanes {
            sde: &self.sde,
            system: scheme.system(),
        };
        let (state, h) = (KernelState { r, v, dw }, self.h);
        let mut parts = lane_parts::<Sd, N>(zero);
        let (mut next_r, mut next_v, mut dmu) = ([zero; N], [zero; N], [zero]);
        let mut next = Next {
            r: &mut next_r,
            v: &mut next_v,
            dmu: &mut dmu,
        };
        let stepped = match self.method {
            Method::Euler => euler_step(&mut kernel, state, h, None, &mut parts.view(), &mut next),
            Method::Truncated(c) => {
                euler_step(&mut kernel, state, h, Some(c), &mut parts.view(), &mut next)
            }
            Method::Heun => {
                let mut predictor = lane_parts::<Sd, N>(zero);
                let predictor = &mut predictor.view();
                heun_step(
                    &mut kernel,
                    state,
                    h,
                    &mut parts.view(),
                    predictor,
                    &mut next,
                )
            }
            Method::Projected(_) => {
                let projection = self.projection.as_ref()?;
                let mut kernel = Projecting { kernel, projection };
                projected_step(&mut kernel, state, h, &mut parts.view(), &mut next)
            }
        }
        .ok()?;
        Some(LaneStep {
            ok: stepped.ok,
            r: next_r,
            v: next_v,
            dmu: dmu[0],
            record: LaneRecord {
                newton_iterations: stepped.newton_iterations,
                ..LaneRecord::plain(stepped.eta)
            },
        })
    }
}

/// [`EulerParts`] of W lanes, zero.
#[inline(always)]
fn lane_parts<Sd: Simd, const N: usize>(
    zero: Lanes<Sd>,
) -> EulerParts<[Lanes<Sd>; N], [Lanes<Sd>; 1]> {
    EulerParts {
        accel: [zero; N],
        mu_rate: [zero],
        noise_v: [zero; N],
        noise_mu: [zero],
    }
}

/// The constraint's forms with the diagonal of M^-1 ([`SphereRoot`]'s, its solver unused).
struct SphereSde<E, const N: usize> {
    forms: SphereRoot<E, N>,
    inverse_mass: [f64; N],
}

/// The first N rows of `x`.
#[inline(always)]
fn coordinates<Sd: Simd, const N: usize>(x: &[Lanes<Sd>]) -> &[Lanes<Sd>; N] {
    x.first_chunk::<N>()
        .expect("a fixed-size kernel's rows have N coordinates")
}

impl<E: Equations, const N: usize> SphereSde<E, N> {
    fn new<S: System>(system: &S, constraint: &E) -> Self {
        let mass = system.mass();
        let inverse_mass = std::array::from_fn(|k| mass.inverse_diagonal_entry(k).unwrap_or(0.0));
        let settings = SolverSettings::default();
        Self {
            forms: SphereRoot::new(constraint, inverse_mass, &settings, f64::INFINITY),
            inverse_mass,
        }
    }

    /// `InherentSde::constrain_force` with the factor 1 / G_M(r) (`inverse_gram`) and the
    /// force f: dv = M^-1 [f + grad g dmu] into `dv`, and returns
    /// dmu = -G_M^-1 { Dg M^-1 f + D^2 g(v, v) } (the curvature term only with `curvature`,
    /// which is the drift's dt = 1).
    #[inline(always)]
    fn constrain<Sd: Simd>(
        &self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], inverse_gram: Lanes<Sd>,
        mut force: [Lanes<Sd>; N], curvature: bool, dv: &mut [Lanes<Sd>],
    ) -> Lanes<Sd> {
        for (f, w) in force.iter_mut().zip(self.inverse_mass) {
            *f = *f * w;
        }
        let (r, v) = (coordinates::<Sd, N>(r), coordinates::<Sd, N>(v));
        let mut dmu = self.forms.normal_rate(r, &force);
        if curvature {
            dmu = dmu + self.forms.curvature_rate(r, v, v) * 1.0;
        }
        let dmu = -(dmu * inverse_gram);
        let dv = dv
            .first_chunk_mut::<N>()
            .expect("a fixed-size kernel's rows have N coordinates");
        self.forms.displace(r, dmu, &force, dv);
        dmu
    }

    /// G_M(r) = Dg(r) M^-1 grad g(r) (`SphereRoot::value_and_gram` at x = r).
    #[inline(always)]
    fn gram<Sd: Simd>(&self, r: &[Lanes<Sd>]) -> Lanes<Sd> {
        let r = coordinates::<Sd, N>(r);
        let [_, gram] = self.forms.value_and_gram(r, r);
        gram
    }
}

/// The lanes' [`InherentKernel`]: the sphere's closed forms with a diagonal mass and the
/// system's lane formulas.
struct SphereLanes<'a, S, E, const N: usize> {
    sde: &'a SphereSde<E, N>,
    system: &'a S,
}

/// A system without a lane form: its group steps through the scalar solver.
struct NoLaneForm;

impl<S: System, Sd: Simd, E: Equations, const N: usize> InherentKernel<Lanes<Sd>>
    for SphereLanes<'_, S, E, N>
{
    type Error = NoLaneForm;

    /// `OnePath::parts` in closed form: G_M(r) factored as 1 / G_M(r) where finite and
    /// nonzero.
    #[inline(always)]
    fn parts(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], dw: &[Lanes<Sd>],
        parts: &mut Parts<'_, Lanes<Sd>>,
    ) -> Result<LaneMask<Sd>, NoLaneForm> {
        let (sde, zero) = (self.sde, r[0].splat_like(0.0));
        let gram = sde.gram(r);
        let mut ok = gram.is_finite().and(!gram.eq(zero));
        let inverse_gram = zero.splat_like(1.0) / gram;
        let mut force = [zero; N];
        if !self.system.drift(r, v, &mut force) {
            return Err(NoLaneForm);
        }
        parts.mu_rate[0] = sde.constrain(r, v, inverse_gram, force, true, parts.accel);
        ok = ok.and(all_finite(parts.accel));
        if dw.is_empty() {
            parts.noise_v.fill(zero);
            parts.noise_mu.fill(zero);
        } else {
            let mut force = [zero; N];
            if !self.system.add_noise(r, v, dw, &mut force) {
                return Err(NoLaneForm);
            }
            parts.noise_mu[0] = sde.constrain(r, v, inverse_gram, force, false, parts.noise_v);
            ok = ok.and(all_finite(parts.noise_v));
        }
        Ok(ok)
    }

    #[inline(always)]
    fn finite(&self, _what: &'static str, x: &[Lanes<Sd>]) -> Result<LaneMask<Sd>, NoLaneForm> {
        Ok(all_finite(x))
    }
}

impl<S: System, Sd: Simd, E: Equations, const N: usize> ProjectionKernel<Lanes<Sd>>
    for Projecting<SphereLanes<'_, S, E, N>, &SphereRoot<E, N>>
{
    /// The root's point of the projection of y = r along its normal ([`SphereRoot`], in closed
    /// form: no Newton iterations; y itself where gamma = 0).
    #[inline(always)]
    fn project_position(
        &mut self, r: &mut [Lanes<Sd>],
    ) -> Result<(LaneMask<Sd>, Lanes<Sd>), NoLaneForm> {
        let y: [Lanes<Sd>; N] = std::array::from_fn(|i| r[i]);
        let position = self.projection.solve(&y, &y);
        let zero = y[0].splat_like(0.0);
        let at_y = position.gamma.eq(zero);
        for (ri, (yi, xi)) in r.iter_mut().zip(y.iter().zip(&position.x)) {
            *ri = Lanes::select(at_y, *yi, *xi);
        }
        Ok((position.ok, zero))
    }

    /// G_M(r) = r^T M^-1 r / rho^4, lambda = G_M^-1 Dg(r) u, then v = u + M^-1 grad g(r)
    /// (-lambda), for u the v given.
    #[inline(always)]
    fn project_velocity(
        &mut self, r: &[Lanes<Sd>], v: &mut [Lanes<Sd>],
    ) -> Result<LaneMask<Sd>, NoLaneForm> {
        let sde = self.kernel.sde;
        let u: [Lanes<Sd>; N] = std::array::from_fn(|i| v[i]);
        let zero = u[0].splat_like(0.0);
        let gram = sde.gram(r);
        let r = coordinates::<Sd, N>(r);
        let lambda = sde.forms.normal_rate(r, &u) * (zero.splat_like(1.0) / gram);
        let v = v
            .first_chunk_mut::<N>()
            .expect("a fixed-size kernel's rows have N coordinates");
        sde.forms.displace(r, -lambda, &u, v);
        Ok(gram.is_finite().and(!gram.eq(zero)))
    }
}

/// The lanes where every coordinate is finite.
#[inline(always)]
fn all_finite<Sd: Simd>(x: &[Lanes<Sd>]) -> LaneMask<Sd> {
    let mut ok = x[0].is_finite();
    for xi in &x[1..] {
        ok = ok.and(xi.is_finite());
    }
    ok
}
