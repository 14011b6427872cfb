//! The refusals of the crate: every one names what, where (a byte position in the text where
//! there is one) and by how much.

/// Why an expression, a symbol table or a program was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExprError {
    /// The text is not an expression of the grammar (crate docs): `message` says what was
    /// expected at byte `position`.
    #[error("at byte {position}: {message}")]
    Syntax {
        /// Byte offset in the text.
        position: usize,
        /// What was found, or expected, there.
        message: String,
    },
    /// A name that is neither a symbol of the table nor a constant of the grammar.
    #[error("at byte {position}: unknown symbol `{name}`{hint}")]
    UnknownSymbol {
        /// The name as written.
        name: String,
        /// Byte offset of the name.
        position: usize,
        /// The nearest known name, as a sentence ("; did you mean `x1`?"), or empty.
        hint: String,
    },
    /// A call of a function the grammar does not have.
    #[error("at byte {position}: unknown function `{name}`; the functions are {known}")]
    UnknownFunction {
        /// The name as written.
        name: String,
        /// Byte offset of the name.
        position: usize,
        /// The functions of the grammar.
        known: String,
    },
    /// A function called with the wrong number of arguments.
    #[error("at byte {position}: `{name}` takes {expected} argument(s), found {found}")]
    Arity {
        /// The function.
        name: String,
        /// Byte offset of the call.
        position: usize,
        /// Its number of arguments.
        expected: usize,
        /// The number written.
        found: usize,
    },
    /// A limit of the crate exceeded (crate docs, "Limits"): `what` is beyond `limit`.
    #[error("{what}: {found} is beyond the limit of {limit}")]
    Limit {
        /// What was counted (text bytes, nesting depth, nodes, symbols, program operations).
        what: &'static str,
        /// Its count.
        found: usize,
        /// The limit.
        limit: usize,
        /// Byte offset in the text, where the count is one of a text's.
        position: Option<usize>,
    },
    /// A symbol name that the table cannot take.
    #[error("symbol `{name}`: {reason}")]
    BadSymbol {
        /// The name.
        name: String,
        /// Why (not an identifier, a function's or a constant's name, already taken).
        reason: String,
    },
    /// A parameter whose value is infinite or NaN.
    #[error("parameter `{name}` = {value} is not finite")]
    NonFiniteParameter {
        /// The parameter.
        name: String,
        /// Its value.
        value: f64,
    },
    /// A list or a set of inputs of the wrong length.
    #[error("{what}: {found} given, {expected} expected")]
    Shape {
        /// What was counted.
        what: &'static str,
        /// The length needed.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// An expression that does not belong to the graph it was given to.
    #[error("expression {id} is not in this graph of {nodes} nodes")]
    ForeignExpression {
        /// The expression's index.
        id: usize,
        /// The graph's size.
        nodes: usize,
    },
}

impl ExprError {
    /// The byte offset in the expression's text the error points at, if it has one.
    pub fn position(&self) -> Option<usize> {
        match self {
            ExprError::Syntax { position, .. }
            | ExprError::UnknownSymbol { position, .. }
            | ExprError::UnknownFunction { position, .. }
            | ExprError::Arity { position, .. } => Some(*position),
            ExprError::Limit { position, .. } => *position,
            _ => None,
        }
    }

    /// The error under the text it was found in, a caret at its position:
    ///
    /// ```text
    /// x1 + * y1
    ///      ^ expected an operand
    /// ```
    ///
    /// (the caret counts characters, not bytes, so that it stands under the right one in any
    /// script; tabs in the text are kept in the padding). Without a position: the message.
    pub fn caret(&self, text: &str) -> String {
        let Some(position) = self.position() else {
            return self.to_string();
        };
        let position = position.min(text.len());
        let before = text.get(..position).unwrap_or(text);
        let padding: String = before
            .chars()
            .map(|c| if c == '\t' { '\t' } else { ' ' })
            .collect();
        let line = text.replace(['\n', '\r'], " ");
        format!("{line}\n{padding}^ {}", self.detail())
    }

    /// The message without its position (what the caret line shows).
    fn detail(&self) -> String {
        match self {
            ExprError::Syntax { message, .. } => message.clone(),
            ExprError::UnknownSymbol { name, hint, .. } => format!("unknown symbol `{name}`{hint}"),
            ExprError::UnknownFunction { name, known, .. } => {
                format!("unknown function `{name}`; the functions are {known}")
            }
            ExprError::Arity {
                name,
                expected,
                found,
                ..
            } => format!("`{name}` takes {expected} argument(s), found {found}"),
            other => other.to_string(),
        }
    }
}
