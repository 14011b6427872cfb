//! The functions f of the final state whose mean E[f(X_T)] an MLMC study estimates.

use std::sync::Arc;

use super::settings::MlmcError;

/// The formula of an observable: f(r_T, v_T).
type Formula = dyn Fn(&[f64], &[f64]) -> f64 + Send + Sync;

/// A named observable f(r_T, v_T).
#[derive(Clone)]
pub struct Observable {
    name: String,
    formula: Arc<Formula>,
}

/// The built-in observables, with what they compute.
pub const BUILT_IN: [(&str, &str); 2] = [
    (
        "cos-angle",
        "r_T . r_0 / |r_0|^2: on a sphere about 0, the cosine of the angle between r_T and r_0",
    ),
    (
        "end-to-end",
        "|r_last - r_first|: the distance between the first and the last bead of a 3-d chain",
    ),
];

impl Observable {
    /// An observable named `name` with the formula f(r, v).
    pub fn new(
        name: impl Into<String>,
        formula: impl Fn(&[f64], &[f64]) -> f64 + Send + Sync + 'static,
    ) -> Self {
        Self {
            name: name.into(),
            formula: Arc::new(formula),
        }
    }

    /// The built-in observable `name` for a system with initial position `r0`; fails if there
    /// is none of that name or it does not apply to the system.
    pub fn built_in(name: &str, r0: &[f64]) -> Result<Self, MlmcError> {
        let not_applicable = |reason: String| MlmcError::ObservableNotApplicable {
            name: name.into(),
            reason,
        };
        match name {
            "cos-angle" => {
                let norm2: f64 = r0.iter().map(|x| x * x).sum();
                if norm2 == 0.0 {
                    return Err(not_applicable("r_0 = 0 has no direction".into()));
                }
                let r0 = r0.to_vec();
                Ok(Self::new(name, move |r, _| {
                    r.iter().zip(&r0).map(|(a, b)| a * b).sum::<f64>() / norm2
                }))
            }
            "end-to-end" => {
                let n = r0.len();
                if n < 6 || !n.is_multiple_of(3) {
                    return Err(not_applicable(format!(
                        "the system has {n} coordinates, not a chain of at least two 3-d beads"
                    )));
                }
                Ok(Self::new(name, move |r, _| {
                    (0..3)
                        .map(|j| (r[n - 3 + j] - r[j]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                }))
            }
            _ => Err(MlmcError::UnknownObservable {
                name: name.into(),
                known: BUILT_IN.map(|(n, _)| n).join(", "),
            }),
        }
    }

    /// The name used in reports.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// f(r, v).
    pub fn value(&self, r: &[f64], v: &[f64]) -> f64 {
        (self.formula)(r, v)
    }
}

impl std::fmt::Debug for Observable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Observable")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_observables_compute_their_formulas_and_refuse_what_does_not_fit() {
        let cos = Observable::built_in("cos-angle", &[0.0, -1.0]).unwrap();
        let phi = 0.3f64;
        assert!((cos.value(&[phi.sin(), -phi.cos()], &[0.0, 0.0]) - phi.cos()).abs() < 1e-15);
        let chain = Observable::built_in("end-to-end", &[0.0; 6]).unwrap();
        assert_eq!(chain.value(&[0.0, 0.0, 0.0, 3.0, 4.0, 0.0], &[0.0; 6]), 5.0);
        assert!(matches!(
            Observable::built_in("end-to-end", &[0.0, -1.0]),
            Err(MlmcError::ObservableNotApplicable { .. })
        ));
        assert!(matches!(
            Observable::built_in("energy", &[0.0, -1.0]),
            Err(MlmcError::UnknownObservable { .. })
        ));
    }
}
