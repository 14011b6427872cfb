//! The refusals of a specification: each names the entry of the spec ([`SpecError::key`]) and
//! says what, where and by how much ([`SpecErrorKind`]).

use sdae_expr::{ExprError, ExprId, Graph, Program};

/// A specification refused: `key` names its entry (`"constraints[1]"`, `"potential"`,
/// `"observables.energy"`, `"position"`, `"mass"`, ...), `kind` says why. `Display` gives
/// both; for an expression, the text on a line of its own with a caret under the error's
/// position:
///
/// ```text
/// constraints[0]:
/// x1^2 + y1^2 - L^2 +
///                    ^ expected an operand
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SpecError {
    /// The spec entry refused.
    pub key: String,
    /// Why.
    pub kind: SpecErrorKind,
}

/// Why a specification was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpecErrorKind {
    /// An expression that does not parse, names an unknown symbol (with the nearest known
    /// name), or is beyond a limit: `caret` is the text with a caret under the position.
    #[error("{caret}")]
    Expression {
        /// What sdae-expr found.
        error: ExprError,
        /// The text and the caret line ([`ExprError::caret`]).
        caret: String,
    },
    /// A name that cannot be given: not a name, reserved, or given twice.
    #[error("`{name}` {reason}")]
    Name {
        /// The name.
        name: String,
        /// Why.
        reason: String,
    },
    /// A list of the wrong length.
    #[error("{found} given, {expected} expected ({what})")]
    Length {
        /// What the length must match.
        what: String,
        /// The length needed.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// A number out of its range.
    #[error("{value} at index {index}: {rule}")]
    Value {
        /// The offending value.
        value: f64,
        /// Its index in its list (0 for a single number).
        index: usize,
        /// What it must satisfy.
        rule: &'static str,
    },
    /// Entries that do not go together, or one that is missing.
    #[error("{0}")]
    Conflict(String),
    /// The constraints' Jacobian at the initial position has rank below m.
    #[error(
        "the Jacobian of the {m} constraints has rank {rank} < {m} at the initial position (its largest entry is {largest:e}, the next pivot of its elimination {pivot:e}, below 1e-10 of it): the constraints are not independent there"
    )]
    RankDeficient {
        /// The rank found.
        rank: usize,
        /// The number of constraints.
        m: usize,
        /// The largest entry of the Jacobian.
        largest: f64,
        /// The pivot below the tolerance.
        pivot: f64,
    },
    /// The initial state is off the manifold or off its tangent space.
    #[error(
        "{what} = {residual:e} at constraint {index} is beyond the tolerance {tolerance:e} (set `project = true` to project the initial state)"
    )]
    OffManifold {
        /// "|g(r0)|" or "|Dg(r0) v0|".
        what: &'static str,
        /// The largest residual.
        residual: f64,
        /// The constraint it belongs to.
        index: usize,
        /// The tolerance.
        tolerance: f64,
    },
    /// Projecting the initial position onto the manifold did not converge.
    #[error(
        "projecting the initial position onto g = 0 left |g| = {residual:e} after {iterations} Newton iterations (tolerance {tolerance:e})"
    )]
    Projection {
        /// The residual left.
        residual: f64,
        /// The iterations taken.
        iterations: usize,
        /// The tolerance.
        tolerance: f64,
    },
    /// A size beyond a limit of the crate (crate docs, "Limits").
    #[error("{what}: {found} is beyond the limit of {limit}")]
    Limit {
        /// What was counted.
        what: &'static str,
        /// Its count.
        found: usize,
        /// The limit.
        limit: usize,
    },
}

/// The most characters of an expression a refusal shows: of a longer one, the
/// `SHOWN_CHARS / 2` on either side of the error's position.
pub const SHOWN_CHARS: usize = 160;

/// [`ExprError::caret`], or for a long text the part around the position with the caret
/// under it and the error's own message (which gives the byte position).
fn caret(text: &str, error: &ExprError) -> String {
    if text.chars().count() <= SHOWN_CHARS {
        return error.caret(text);
    }
    let position = error.position().unwrap_or(0).min(text.len());
    let half = SHOWN_CHARS / 2;
    let before: Vec<usize> = text[..position].char_indices().map(|(i, _)| i).collect();
    let start = before.len().checked_sub(half).map_or(0, |k| before[k]);
    let end = text[position..]
        .char_indices()
        .nth(half)
        .map_or(text.len(), |(i, _)| position + i);
    let (open, close) = (
        if start > 0 { "..." } else { "" },
        if end < text.len() { "..." } else { "" },
    );
    let shown = text[start..end].replace(['\n', '\r'], " ");
    let padding = " ".repeat(open.len() + text[start..position].chars().count());
    format!("{open}{shown}{close}\n{padding}^ {error}")
}

impl std::fmt::Display for SpecError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.kind {
            SpecErrorKind::Expression { caret, .. } => write!(f, "{}:\n{caret}", self.key),
            kind => write!(f, "{}: {kind}", self.key),
        }
    }
}

impl std::error::Error for SpecError {}

impl SpecError {
    /// An error of entry `key`.
    pub fn new(key: impl Into<String>, kind: SpecErrorKind) -> Self {
        Self {
            key: key.into(),
            kind,
        }
    }

    /// The refusal of expression `text` at entry `key`, with its caret line (of a text longer
    /// than [`SHOWN_CHARS`] characters, the part around the position).
    pub fn expression(key: impl Into<String>, text: &str, error: ExprError) -> Self {
        let caret = caret(text, &error);
        Self::new(key, SpecErrorKind::Expression { error, caret })
    }

    /// A conflict or a missing entry at `key`.
    pub(crate) fn conflict(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(key, SpecErrorKind::Conflict(message.into()))
    }

    /// A list at `key` of `found` entries where `expected` are needed.
    pub(crate) fn length(
        key: impl Into<String>, what: impl Into<String>, expected: usize, found: usize,
    ) -> Self {
        Self::new(
            key,
            SpecErrorKind::Length {
                what: what.into(),
                expected,
                found,
            },
        )
    }
}

/// Compiles `outputs`, naming entry `key` if a limit refuses them.
pub(crate) fn compile(graph: &Graph, outputs: &[ExprId], key: &str) -> Result<Program, SpecError> {
    Program::compile(graph, outputs).map_err(|error| SpecError::expression(key, "", error))
}
