//! Observables: named scalar functions f(r, v) of a path's state, evaluated on the paths of a
//! block (see [`Observing`](crate::Observing)) or averaged in time along them.
//!
//! ```
//! use sdae_lockstep::Observable;
//! // The angle of a planar pendulum from the downward vertical, as a user's closure.
//! let angle = Observable::new("angle", |r, _v| r[0].atan2(-r[1]));
//! assert_eq!(angle.name(), "angle");
//! assert!((angle.value(&[1.0, 0.0], &[0.0, 0.0]) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
//! ```

use std::fmt;
use std::sync::Arc;

/// The function of an observable: f(r, v).
pub type ObservableFunction = dyn Fn(&[f64], &[f64]) -> f64 + Send + Sync;

/// A named scalar function f(r, v) of the state.
#[derive(Clone)]
pub struct Observable {
    name: String,
    function: Arc<ObservableFunction>,
}

impl Observable {
    /// The observable `name` computing `f(r, v)`.
    pub fn new(
        name: impl Into<String>, f: impl Fn(&[f64], &[f64]) -> f64 + Send + Sync + 'static,
    ) -> Self {
        Self {
            name: name.into(),
            function: Arc::new(f),
        }
    }

    /// The observable `name` computing the boxed function `f(r, v)` (without boxing it again).
    pub fn from_boxed(name: impl Into<String>, f: Box<ObservableFunction>) -> Self {
        Self {
            name: name.into(),
            function: Arc::from(f),
        }
    }

    /// Its name (as in a scene's `[weak]` table and the reports).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// f(r, v).
    pub fn value(&self, r: &[f64], v: &[f64]) -> f64 {
        (self.function)(r, v)
    }
}

impl fmt::Debug for Observable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Observable({})", self.name)
    }
}

/// Observables are equal when their names are (a closure cannot be compared).
impl PartialEq for Observable {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}
