//! The step of [`Stepper`](crate::Stepper) for a sphere constraint with a diagonal mass, over W
//! lanes: eq. 3.2 for eta, the closed-form kappa root of the quadratic kappa system (seed eq.
//! 3.1 upper part, the root connected to 0 of Appendix B), and the velocity update with lambda
//! from Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~ (eq. 3.1 lower part). Each formula is the
//! scalar stepper's, with the same floating-point operations in the same order.

use pulp::{Simd, WithSimd};
use sdae_ift::{Certificate, Method};
use sdae_manifold::{Constraint, Mass, Sphere};
use sdae_model::lanes::{LaneMask, Lanes};
use sdae_model::{Scheme, StepOutcome, System};

use super::{Ensemble, load_rows};

/// The largest sphere dimension stepped in lanes (the planar and the spherical pendulum).
pub(super) const MAX_DIM: usize = 3;

/// One step of every path of an ensemble whose constraint is a sphere.
pub(super) struct StepAll<'a, S: System> {
    pub(super) ensemble: &'a mut Ensemble<S>,
    pub(super) h: f64,
    pub(super) dw: &'a [f64],
}

impl<S: System> WithSimd for StepAll<'_, S> {
    type Output = ();
    #[inline(always)]
    fn with_simd<Sd: Simd>(self, simd: Sd) {
        let Self { ensemble, h, dw } = self;
        let sphere = *ensemble
            .stepper
            .system()
            .constraint()
            .as_sphere()
            .expect("StepAll runs for sphere constraints only");
        match sphere.dim() {
            2 => step_groups::<S, Sd, 2>(simd, ensemble, &sphere, h, dw),
            _ => step_groups::<S, Sd, 3>(simd, ensemble, &sphere, h, dw),
        }
    }
}

/// Every group of W lanes; lanes the closed form leaves open go through the scalar stepper.
#[inline(always)]
fn step_groups<S: System, Sd: Simd, const N: usize>(
    simd: Sd,
    ensemble: &mut Ensemble<S>,
    sphere: &Sphere,
    h: f64,
    dw: &[f64],
) {
    let width = Sd::F64_LANES;
    let l = ensemble.lane_dw.len();
    let kernel = Kernel::<N>::new(ensemble, sphere, h);
    let Some(kernel) = kernel else {
        for p in 0..ensemble.paths {
            ensemble.step_one(p, h, dw);
        }
        return;
    };
    let stride = ensemble.stride;
    for offset in (0..stride).step_by(width) {
        let alive = Lanes::load(simd, &ensemble.alive[offset..]);
        let alive = alive.eq(alive.splat_like(1.0));
        let r: [Lanes<Sd>; N] = load_rows(simd, &ensemble.r, stride, offset, N);
        let v: [Lanes<Sd>; N] = load_rows(simd, &ensemble.v, stride, offset, N);
        let noise: [Lanes<Sd>; N] = load_rows(simd, dw, stride, offset, l);
        let system = ensemble.stepper.system();
        let Some(lanes) = kernel.step(system, &r, &v, &noise[..l]) else {
            for p in offset..(offset + width).min(ensemble.paths) {
                ensemble.step_one(p, h, dw);
            }
            continue;
        };
        let done = lanes.ok.and(alive);
        for i in 0..N {
            let row = i * stride + offset;
            Lanes::select(done, lanes.r[i], r[i]).store(&mut ensemble.r[row..]);
            Lanes::select(done, lanes.v[i], v[i]).store(&mut ensemble.v[row..]);
        }
        // mu_{k+1} = mu_k + lambda_{k+1} (seed eq. 1.4; a sphere has one constraint).
        let mu = Lanes::load(simd, &ensemble.mu[offset..]);
        Lanes::select(done, mu + lanes.lambda, mu).store(&mut ensemble.mu[offset..]);
        let (alive, done) = (mask_values(alive), mask_values(done));
        let decided = lanes.values(kernel.radius, kernel.monitor_velocity);
        for lane in 0..width {
            let p = offset + lane;
            if p >= ensemble.paths || !alive[lane] {
                continue;
            }
            if done[lane] {
                ensemble.diagnostics[p].record(&decided.outcome(lane), h);
            } else {
                ensemble.step_one(p, h, dw);
            }
        }
    }
}

/// The lanes of a mask as booleans (the first W entries).
#[inline(always)]
fn mask_values<Sd: Simd>(mask: LaneMask<Sd>) -> [bool; LANES_MAX] {
    let one = Lanes::splat(mask.simd(), 1.0);
    let mut values = [0.0; LANES_MAX];
    Lanes::select(mask, one, one.splat_like(0.0)).store(&mut values);
    values.map(|x| x == 1.0)
}

/// The widest W.
const LANES_MAX: usize = sdae_model::LANE_BLOCK;

/// The constants of one step: the scheme's and the sphere's.
struct Kernel<const N: usize> {
    h: f64,
    c_eta: Option<f64>,
    local_size: bool,
    rescale_noise: bool,
    monitor_velocity: bool,
    radius: f64,
    tolerance: f64,
    plausibility_factor: f64,
    max_contraction: f64,
    /// The sphere's rho and 1/rho^2.
    rho: f64,
    inv_r2: f64,
    /// 4 eps d, the factor of the residual floor (`Sphere::roundoff`).
    floor_factor: f64,
    /// (M^-1)_ii.
    inverse_mass: [f64; N],
}

/// What the closed form computed for W lanes; `ok` marks the lanes it decided.
struct Decided<Sd: Simd, const N: usize> {
    ok: LaneMask<Sd>,
    r: [Lanes<Sd>; N],
    v: [Lanes<Sd>; N],
    /// lambda_{k+1}, the increment of mu.
    lambda: Lanes<Sd>,
    eta: Lanes<Sd>,
    residual: Lanes<Sd>,
    velocity_residual: Lanes<Sd>,
    norm: Lanes<Sd>,
    first_step: Lanes<Sd>,
    contraction: Lanes<Sd>,
}

impl<Sd: Simd, const N: usize> Decided<Sd, N> {
    /// The per-lane numbers of the step's outcomes, as plain values.
    #[inline(always)]
    fn values(&self, radius: f64, monitor_velocity: bool) -> DecidedValues {
        let plain = |x: Lanes<Sd>| {
            let mut values = [0.0; LANES_MAX];
            x.store(&mut values);
            values
        };
        DecidedValues {
            radius,
            monitor_velocity,
            eta: plain(self.eta),
            residual: plain(self.residual),
            velocity_residual: plain(self.velocity_residual),
            norm: plain(self.norm),
            first_step: plain(self.first_step),
            contraction: plain(self.contraction),
        }
    }
}

/// [`Decided`]'s numbers per lane.
struct DecidedValues {
    radius: f64,
    monitor_velocity: bool,
    eta: [f64; LANES_MAX],
    residual: [f64; LANES_MAX],
    velocity_residual: [f64; LANES_MAX],
    norm: [f64; LANES_MAX],
    first_step: [f64; LANES_MAX],
    contraction: [f64; LANES_MAX],
}

impl DecidedValues {
    /// The scalar stepper's outcome of a closed-form step of lane `lane`.
    #[inline(always)]
    fn outcome(&self, lane: usize) -> StepOutcome {
        let residual = self.residual[lane];
        StepOutcome {
            eta: self.eta[lane],
            newton_iterations: 0,
            position_residual: Some(residual),
            certificate: Some(Certificate {
                iterations: 0,
                homotopy_steps: 0,
                method: Method::ClosedForm,
                residual,
                norm: self.norm[lane],
                radius: self.radius,
                first_step: self.first_step[lane],
                contraction: self.contraction[lane],
                rounding: 0.0,
            }),
            velocity_residual: self.monitor_velocity.then(|| self.velocity_residual[lane]),
        }
    }
}

impl<const N: usize> Kernel<N> {
    /// The constants, or `None` if the mass is not diagonal.
    fn new<S: System>(ensemble: &Ensemble<S>, sphere: &Sphere, h: f64) -> Option<Self> {
        let mass = ensemble.stepper.system().mass();
        if !<S::Mass as Mass>::DIAGONAL {
            return None;
        }
        let mut inverse_mass = [0.0; N];
        for (k, w) in inverse_mass.iter_mut().enumerate() {
            *w = mass.inverse_diagonal_entry(k).unwrap_or(0.0);
        }
        let config = ensemble.stepper.config();
        Some(Self {
            h,
            c_eta: config.c_eta,
            local_size: config.local_size,
            rescale_noise: config.rescale_noise,
            monitor_velocity: config.monitor_velocity_constraint,
            radius: config.c_kappa,
            tolerance: config.solver.tolerance,
            plausibility_factor: config.solver.plausibility_factor,
            max_contraction: config.solver.max_contraction,
            rho: sphere.radius(),
            inv_r2: sphere.inverse_radius_squared(),
            floor_factor: 4.0 * f64::EPSILON * (N as f64),
            inverse_mass,
        })
    }

    /// The step of W lanes from (r, v) with increments dw; `None` if the system has no lane
    /// form.
    #[inline(always)]
    fn step<S: System, Sd: Simd>(
        &self,
        system: &S,
        r: &[Lanes<Sd>; N],
        v: &[Lanes<Sd>; N],
        dw: &[Lanes<Sd>],
    ) -> Option<Decided<Sd, N>> {
        let zero = r[0].splat_like(0.0);
        let one = zero.splat_like(1.0);
        let mut a = [zero; N];
        if !system.drift_lanes(r, v, &mut a) {
            return None;
        }
        let v_norm2 = dot(v, v);
        let a_norm2 = dot(&a, &a);
        let mut ok = v_norm2.is_finite().and(a_norm2.is_finite());

        // eta of eq. 3.2 (or the sphere's local measure w = |v|/rho, alpha = |a|/rho).
        let eta = match self.c_eta {
            None => one,
            Some(c_eta) => {
                let motion = if self.local_size {
                    let w = v_norm2.sqrt() / self.rho;
                    w.max(w * w).max(a_norm2.sqrt() / self.rho)
                } else {
                    let speed = v_norm2.sqrt();
                    speed.max(speed * speed).max(a_norm2.sqrt())
                };
                let size = motion * self.h;
                let c = zero.splat_like(c_eta);
                Lanes::select(c.lt(size), c / size, one)
            }
        };
        let eta_h = eta * self.h;
        let mut y = [zero; N];
        let mut max_abs_y = zero;
        for i in 0..N {
            y[i] = r[i] + eta_h * v[i];
            max_abs_y = max_abs_y.max(y[i].abs());
        }
        let floor = zero.splat_like(self.floor_factor) * max_abs_y * max_abs_y * self.inv_r2;
        let tolerance = zero.splat_like(self.tolerance).max(floor);

        // The quadratic R(gamma) = c0 + c1 gamma + c2 gamma^2 (`Sphere::kappa_quadratic`).
        let (mut yy, mut yu, mut uu) = (zero, zero, zero);
        for i in 0..N {
            let u = r[i] * self.inverse_mass[i];
            yy = yy + y[i] * y[i];
            yu = yu + y[i] * u;
            uu = uu + u * u;
        }
        let c = self.inv_r2;
        let c0 = (one - yy * c) * 0.5;
        let c1 = yu * c * c;
        let c2 = uu * -0.5 * c * c * c;
        ok = ok
            .and(c0.is_finite())
            .and(c1.is_finite())
            .and(c2.is_finite());
        ok = ok.and(!c1.eq(zero));
        // The root connected to 0 (`BallSolver::solve_quadratic`).
        let first_step = (c0 / c1).abs();
        let discriminant = c1 * c1 - c0 * 4.0 * c2;
        ok = ok.and(!discriminant.lt(zero));
        let root = discriminant.sqrt();
        let signed_root = Lanes::select(c1.lt(zero), -root, root);
        let gamma = Lanes::select(c0.abs().le(tolerance), zero, c0 * -2.0 / (c1 + signed_root));
        let norm = gamma.abs();
        ok = ok.and(norm.lt(zero.splat_like(self.radius)));
        let bound = first_step * self.plausibility_factor;
        let implausible = bound
            .lt(norm)
            .and(zero.splat_like(64.0 * f64::EPSILON).lt(norm));
        ok = ok.and(!implausible);

        // The root's point x = y + M^-1 grad g(r) gamma, its residual and J(gamma).
        let s = -gamma * self.inv_r2;
        let mut x = [zero; N];
        let (mut xx, mut xr) = (zero, zero);
        for i in 0..N {
            let w = self.inverse_mass[i];
            x[i] = s * r[i] * w + y[i];
            xx = xx + x[i] * x[i];
            xr = xr + x[i] * r[i] * w;
        }
        let residual = ((one - xx * self.inv_r2) * 0.5).abs();
        ok = ok.and(residual.le(tolerance));
        let gram = xr * self.inv_r2 * self.inv_r2;
        ok = ok.and(gram.is_finite()).and(!gram.eq(zero));
        let contraction = (c2 * 2.0 * gamma / c1).abs();
        if self.radius.is_finite() {
            ok = ok.and(contraction.lt(zero.splat_like(self.max_contraction)));
        }

        // v~ = v + M^-1 (eta a h + B dw), or sqrt(eta) (sqrt(eta) h a + B dw) when rescaled.
        let scale = if self.rescale_noise {
            Lanes::select(eta.lt(one), eta.sqrt(), one)
        } else {
            one
        };
        let drift_h = if self.rescale_noise {
            scale * self.h
        } else {
            eta_h
        };
        let mut force = [zero; N];
        for i in 0..N {
            force[i] = drift_h * a[i];
        }
        if !system.add_noise_lanes(r, v, dw, &mut force) {
            return None;
        }
        for i in 0..N {
            if self.rescale_noise {
                force[i] = force[i] * scale;
            }
            force[i] = force[i] * self.inverse_mass[i] + v[i];
        }
        // lambda = -Dg(r') v~ / (Dg(r') M^-1 grad g(r)), v' = v~ + M^-1 grad g(r) lambda.
        let lambda = -(-dot(&x, &force) * self.inv_r2) * (one / gram);
        let t = -lambda * self.inv_r2;
        let mut v_new = [zero; N];
        for i in 0..N {
            v_new[i] = t * r[i] * self.inverse_mass[i] + force[i];
        }
        ok = ok.and(dot(&v_new, &v_new).is_finite());
        let velocity_residual = (-dot(&x, &v_new) * self.inv_r2).abs();
        Some(Decided {
            ok,
            r: x,
            v: v_new,
            lambda,
            eta,
            residual,
            velocity_residual,
            norm,
            first_step,
            contraction,
        })
    }
}

/// a . b over N lanes, in order.
#[inline(always)]
fn dot<Sd: Simd, const N: usize>(a: &[Lanes<Sd>; N], b: &[Lanes<Sd>; N]) -> Lanes<Sd> {
    let mut sum = a[0] * b[0];
    for i in 1..N {
        sum = sum + a[i] * b[i];
    }
    sum
}
