//! The drift a(q, v) = -grad V(q) + a_forces(q, v) - gamma v and the noise B(q, v) of a
//! specification, compiled.

use sdae_expr::{ExprId, Graph, Program, SymbolTable};
use sdae_lanes::Real;

use crate::constraint::{Reads, parse};
use crate::error::compile;
use crate::error::{SpecError, SpecErrorKind};
use crate::names::{Q, V, slot};
use crate::scratch;
use crate::spec::{ExpressionSpec, NoiseSpec};

/// The noise B(q, v).
#[derive(Debug, Clone)]
pub(crate) enum NoiseForm {
    /// B = 0: no random numbers are drawn.
    Zero,
    /// B = sigma I.
    Scalar(f64),
    /// B = diag(sigma_i).
    Diagonal(Vec<f64>),
    /// B = diag(b_i(q, v)).
    Expressions(Program),
}

/// The force -grad V(q) + a(q, v).
#[derive(Debug, Clone)]
enum Force {
    /// Zero.
    Zero,
    /// Constants (a uniform field: the program's outputs, without evaluating it).
    Constant(Vec<f64>),
    /// The compiled program.
    Program(Program),
}

/// The compiled drift and noise.
#[derive(Debug, Clone)]
pub(crate) struct Dynamics {
    n: usize,
    force: Force,
    /// Whether the forces read the velocities.
    force_uses_velocity: bool,
    /// gamma.
    pub(crate) friction: f64,
    pub(crate) noise: NoiseForm,
}

impl Dynamics {
    /// The potential, forces, friction and noise of `spec` over n coordinates.
    pub(crate) fn new(
        graph: &mut Graph, table: &SymbolTable, spec: &ExpressionSpec, names: &[String],
    ) -> Result<Self, SpecError> {
        let n = names.len();
        let mut force: Vec<ExprId> = (0..n).map(|_| graph.num(0.0)).collect();
        if let Some(text) = &spec.potential {
            let potential = parse(graph, table, "potential", text, Reads::Coordinates(names))?;
            let gradient = graph
                .gradient(potential, &slot(Q, n))
                .map_err(|error| SpecError::expression("potential", text, error))?;
            force = gradient.into_iter().map(|d| graph.neg(d)).collect();
        }
        if let Some(texts) = &spec.forces {
            if texts.len() != n {
                let what = "one force expression per coordinate";
                return Err(SpecError::length("forces", what, n, texts.len()));
            }
            for (i, text) in texts.iter().enumerate() {
                let a = parse(
                    graph,
                    table,
                    &format!("forces[{i}]"),
                    text,
                    Reads::Velocities,
                )?;
                force[i] = graph.add(force[i], a);
            }
        }
        let zero = force.iter().all(|&f| graph.constant(f) == Some(0.0));
        let force_uses_velocity = force
            .iter()
            .any(|&f| graph.inputs_of(f).iter().any(|v| v.slot == V));
        let (friction, noise) = noise(graph, table, spec, n)?;
        let force = match zero {
            true => Force::Zero,
            false => {
                let program = compile(graph, &force, "forces")?;
                match program.constant_outputs() {
                    Some(values) => Force::Constant(values),
                    None => Force::Program(program),
                }
            }
        };
        Ok(Self {
            n,
            force,
            force_uses_velocity,
            friction,
            noise,
        })
    }

    /// out = a(r, v), n values.
    #[inline(always)]
    pub(crate) fn drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) {
        let out = &mut out[..self.n];
        match &self.force {
            Force::Program(program) => scratch::eval(program, &[r, v], out),
            Force::Constant(values) => {
                for ((o, vi), &c) in out.iter_mut().zip(v).zip(values) {
                    *o = vi.splat_like(c);
                }
            }
            Force::Zero => {
                for (o, vi) in out.iter_mut().zip(v) {
                    *o = vi.splat_like(0.0);
                }
            }
        }
        if self.friction != 0.0 {
            for (o, &vi) in out.iter_mut().zip(v) {
                *o = *o + vi * -self.friction;
            }
        }
    }

    /// The dimension of the Brownian motion: n, or 0 without noise.
    pub(crate) fn noise_dim(&self) -> usize {
        match self.noise {
            NoiseForm::Zero => 0,
            _ => self.n,
        }
    }

    /// out += B(r, v) dw.
    #[inline(always)]
    pub(crate) fn add_noise<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) {
        let out = &mut out[..self.n];
        match &self.noise {
            NoiseForm::Zero => {}
            NoiseForm::Scalar(sigma) => {
                for (o, &w) in out.iter_mut().zip(dw) {
                    *o = *o + w * *sigma;
                }
            }
            NoiseForm::Diagonal(sigma) => {
                for ((o, &w), s) in out.iter_mut().zip(dw).zip(sigma) {
                    *o = *o + w * *s;
                }
            }
            NoiseForm::Expressions(program) => {
                let Some(&seed) = out.first() else { return };
                scratch::with_buffer(self.n, seed, |b| {
                    scratch::eval(program, &[r, v], b);
                    for ((o, &w), bi) in out.iter_mut().zip(dw).zip(b.iter()) {
                        *o = *o + w * *bi;
                    }
                });
            }
        }
    }

    /// (gamma, sigma) where a(q, v) = F(q) - gamma v and B = sigma I.
    pub(crate) fn langevin(&self) -> Option<(f64, f64)> {
        if self.force_uses_velocity {
            return None;
        }
        match self.noise {
            NoiseForm::Zero => Some((self.friction, 0.0)),
            NoiseForm::Scalar(sigma) => Some((self.friction, sigma)),
            _ => None,
        }
    }
}

/// A number of entry `key` that must be finite and >= 0.
fn non_negative(key: &str, value: f64, index: usize) -> Result<f64, SpecError> {
    if value.is_finite() && value >= 0.0 {
        return Ok(value);
    }
    Err(SpecError::new(
        key,
        SpecErrorKind::Value {
            value,
            index,
            rule: "must be finite and >= 0",
        },
    ))
}

/// The friction gamma and the noise: derived from (friction, kT), or as given.
fn noise(
    graph: &mut Graph, table: &SymbolTable, spec: &ExpressionSpec, n: usize,
) -> Result<(f64, NoiseForm), SpecError> {
    match (spec.friction, spec.kt, &spec.noise) {
        (Some(_), Some(_), Some(_)) => Err(SpecError::conflict(
            "noise",
            "given with `friction` and `kT`: the noise is then sqrt(2 friction kT) I; give one or the other",
        )),
        (Some(gamma), Some(kt), None) => {
            let gamma = non_negative("friction", gamma, 0)?;
            let sigma = (2.0 * gamma * non_negative("kT", kt, 0)?).sqrt();
            Ok((gamma, scalar(sigma)))
        }
        (Some(_), None, _) => Err(SpecError::conflict(
            "kT",
            "missing: `friction` makes a Langevin system, which needs the temperature `kT`",
        )),
        (None, Some(_), _) => Err(SpecError::conflict(
            "friction",
            "missing: `kT` is the temperature of a Langevin system, which needs `friction`",
        )),
        (None, None, noise) => Ok((0.0, given_noise(graph, table, noise.as_ref(), n)?)),
    }
}

/// B = sigma I, or no noise for sigma = 0.
fn scalar(sigma: f64) -> NoiseForm {
    if sigma == 0.0 {
        NoiseForm::Zero
    } else {
        NoiseForm::Scalar(sigma)
    }
}

/// The noise as given (none: B = 0).
fn given_noise(
    graph: &mut Graph, table: &SymbolTable, noise: Option<&NoiseSpec>, n: usize,
) -> Result<NoiseForm, SpecError> {
    let check_len = |len: usize| match len == n {
        true => Ok(()),
        false => Err(SpecError::length(
            "noise",
            "one entry per coordinate",
            n,
            len,
        )),
    };
    match noise {
        None => Ok(NoiseForm::Zero),
        Some(NoiseSpec::Intensity(sigma)) => Ok(scalar(non_negative("noise", *sigma, 0)?)),
        Some(NoiseSpec::Intensities(sigma)) => {
            check_len(sigma.len())?;
            for (i, &s) in sigma.iter().enumerate() {
                non_negative("noise", s, i)?;
            }
            Ok(match sigma.iter().all(|&s| s == sigma[0]) {
                true => scalar(sigma[0]),
                false => NoiseForm::Diagonal(sigma.clone()),
            })
        }
        Some(NoiseSpec::Expressions(texts)) => {
            check_len(texts.len())?;
            let b = texts
                .iter()
                .enumerate()
                .map(|(i, text)| {
                    parse(
                        graph,
                        table,
                        &format!("noise[{i}]"),
                        text,
                        Reads::Velocities,
                    )
                })
                .collect::<Result<Vec<_>, _>>()?;
            Ok(NoiseForm::Expressions(compile(graph, &b, "noise")?))
        }
    }
}
