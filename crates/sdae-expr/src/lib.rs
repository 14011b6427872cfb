//! Expressions of a system's coordinates: parsed, differentiated, simplified and compiled to a
//! tape that runs on one path (`f64`) or on W paths in SIMD lanes ([`sdae_lanes::Lanes`]) with
//! the same bits.
//!
//! A constraint, a potential, a noise intensity or an observable is written as text, bound to
//! a [`SymbolTable`] (inputs in slots such as coordinates and velocities, parameters with
//! values), differentiated in a [`Graph`] ([`Graph::diff`], [`Graph::gradient`],
//! [`Graph::jacobian`] with its sparsity pattern, [`Graph::second_directional`] for
//! D^2 g(q)(u, w), [`Graph::is_quadratic`]) and compiled to a [`Program`] evaluated over any
//! [`sdae_lanes::Real`]:
//!
//! ```
//! use sdae_expr::{Graph, Program, SymbolTable, Var};
//!
//! // A double pendulum's constraints, in the plane.
//! let mut table = SymbolTable::new();
//! let q = table.add_inputs(&["x1", "y1", "x2", "y2"])?;
//! table.add_parameter("L1", 1.0)?;
//! table.add_parameter("L2", 0.5)?;
//! let mut graph = Graph::new();
//! let g = [
//!     graph.parse("x1^2 + y1^2 - L1^2", &table)?,
//!     graph.parse("(x2-x1)^2 + (y2-y1)^2 - L2^2", &table)?,
//! ];
//! let vars = table.slot_vars(q);
//! let jacobian = graph.jacobian(&g, &vars)?;
//! // The first constraint does not involve the second mass.
//! assert_eq!(jacobian.pattern(), [(0, 0), (0, 1), (1, 0), (1, 1), (1, 2), (1, 3)]);
//! assert!(graph.is_quadratic(g[1], &vars)?);
//!
//! // Dg w, compiled: inputs q (slot 0) and w (a slot of its own).
//! let w = Var::slot(table.add_unnamed_inputs(4)?, 4);
//! let products = graph.jacobian_vector(&jacobian, &w)?;
//! let program = Program::compile(&graph, &products)?;
//! let (position, direction) = ([0.6, -0.8, 0.9, -1.2], [1.0, 0.0, 0.0, 1.0]);
//! let mut out = [0.0; 2];
//! program.eval(&[&position[..], &direction[..]], &mut out, &mut Vec::new());
//! assert_eq!(out, [2.0 * 0.6, -2.0 * 0.3 + 2.0 * -0.4]);
//!
//! // A parse error shows where.
//! let error = graph.parse("x1 + * y1", &table).unwrap_err();
//! assert_eq!(error.caret("x1 + * y1"), "x1 + * y1\n     ^ expected an operand");
//! # Ok::<(), sdae_expr::ExprError>(())
//! ```
//!
//! # Grammar
//!
//! ```text
//! expression := term (('+' | '-') term)*
//! term       := unary (('*' | '/') unary)*
//! unary      := ('-' | '+') unary | power
//! power      := primary (('^' | '**') unary)?
//! primary    := number | name | name '(' expression (',' expression)* ')' | '(' expression ')'
//! number     := digits ['.' digits] [('e' | 'E') ['+' | '-'] digits]   (or '.' digits ...)
//! name       := (letter | '_') (letter | digit | '_')*                 (ASCII)
//! ```
//!
//! Powers are right-associative and bind tighter than signs: `a^b^c` is `a^(b^c)`, `-x^2` is
//! `-(x^2)`, `2^-1` is one half. Whitespace is free. The functions are `sin`, `cos`, `tan`,
//! `exp`, `log` (natural), `sqrt`, `abs`, `tanh`, `sign` (1, -1, or 0 at zero; the derivative
//! of `abs`) of one argument and `atan2(y, x)` of two; the one constant is `pi`. A name is an
//! input or a parameter of the table the expression is bound to; any other is refused by name
//! ([`ExprError::UnknownSymbol`], with the nearest known name). Tables refuse names of
//! functions and constants.
//!
//! # Evaluation
//!
//! `+ - * /`, negation, `sqrt` and `abs` run in SIMD on lanes, correctly rounded as in `f64`;
//! the other functions and `x^y` for a real exponent run lane by lane with the standard
//! library's f64 functions ([`sdae_lanes::Real::map_each`]). An integer power x^n, |n| <=
//! [`MAX_INTEGER_POWER`], is the sequence of multiplications of [`powi`] on every number type
//! (x^2 = x x, x^3 = (x x) x; x^-n = 1 / x^n). Each lane therefore computes exactly what the
//! `f64` evaluation computes for its path.
//!
//! # Simplification
//!
//! Nodes are simplified as they are built: constants (numbers, parameters, `pi`) are folded
//! with the evaluation's own f64 operations, and x + 0, 0 + x, x - 0, 0 - x = -x, x * 0 = 0,
//! x * 1, x * -1 = -x, 0 / x = 0, x / 1, x^0 = 1, x^1 and --x are rewritten. (x * 0 = 0 and
//! 0 / x = 0 also where x would be infinite or NaN: the algebra of the expression, not of IEEE
//! special values.) The compiler then computes each distinct operation on the same operands
//! once (common subexpression elimination, a + b and b + a alike), keeps each distinct
//! constant once, and makes only rewrites exact for every input, signed zeros included:
//! negations folded into the sums, products and quotients that read them (a + (-b) as a - b),
//! a division by a power of two as the product with its reciprocal. Structural zeros of a Jacobian are its entries that simplify to the
//! constant 0; a second derivative is constant when it simplifies to a number.
//!
//! # Limits
//!
//! Refused with [`ExprError::Limit`] beyond them: an expression text of
//! [`MAX_TEXT_BYTES`] bytes, a nesting of [`MAX_DEPTH`] parentheses, signs and exponents,
//! [`MAX_SYNTAX_NODES`] nodes in one parsed expression, [`MAX_SYMBOLS`] symbols and
//! [`MAX_SLOTS`] input slots in a table, [`MAX_GRAPH_NODES`] nodes in a graph (derivatives
//! included), [`MAX_PROGRAM_OPS`] operations in a program.

mod compile;
mod diff;
mod error;
mod func;
mod graph;
mod parse;
mod symbols;
mod tape;

pub use diff::{Entry, Jacobian};
pub use error::ExprError;
pub use func::{CONSTANTS, FUNCTIONS, Func, MAX_INTEGER_POWER, atan2, powf, powi};
pub use graph::{ExprId, Graph, MAX_GRAPH_NODES, Node};
pub use parse::{BinaryOp, MAX_DEPTH, MAX_SYNTAX_NODES, MAX_TEXT_BYTES, Syntax, SyntaxNode};
pub use symbols::{MAX_SLOTS, MAX_SYMBOLS, Symbol, SymbolTable, Var, edit_distance, is_identifier};
pub use tape::{CompileOptions, MAX_PROGRAM_OPS, Op, Program};
