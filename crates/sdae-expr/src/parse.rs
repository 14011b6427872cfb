//! Text to a syntax tree: a recursive-descent parser of the grammar of the crate docs, every
//! refusal at a byte position.

use crate::ExprError;
use crate::func::{FUNCTIONS, Func};

/// The longest expression text, in bytes.
pub const MAX_TEXT_BYTES: usize = 16 * 1024;

/// The deepest nesting of parentheses, signs and exponents in one expression.
pub const MAX_DEPTH: usize = 100;

/// The most nodes (numbers, names, operations, calls) of one parsed expression.
pub const MAX_SYNTAX_NODES: usize = 8192;

/// A binary operation of the grammar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `^` (or `**`)
    Pow,
}

/// A node of a syntax tree; its operands are indices of earlier nodes.
#[derive(Debug, Clone, PartialEq)]
pub enum SyntaxNode {
    /// A number as written.
    Number(f64),
    /// A name (an input, a parameter or a constant), at byte `position`.
    Name {
        /// The name.
        name: String,
        /// Its byte offset.
        position: usize,
    },
    /// `-a`.
    Neg(usize),
    /// `a op b`.
    Binary(BinaryOp, usize, usize),
    /// `f(a)`.
    Call(Func, usize),
    /// `atan2(y, x)`.
    Atan2(usize, usize),
}

/// A parsed expression, not yet bound to symbols: its nodes, operands before the operations
/// that use them, the root last.
#[derive(Debug, Clone, PartialEq)]
pub struct Syntax {
    nodes: Vec<SyntaxNode>,
}

impl Syntax {
    /// Parses `text` (grammar and limits in the crate docs).
    pub fn parse(text: &str) -> Result<Syntax, ExprError> {
        if text.len() > MAX_TEXT_BYTES {
            return Err(ExprError::Limit {
                what: "expression text bytes",
                found: text.len(),
                limit: MAX_TEXT_BYTES,
                position: Some(MAX_TEXT_BYTES),
            });
        }
        let tokens = lex(text)?;
        let mut parser = Parser {
            tokens,
            at: 0,
            depth: 0,
            nodes: Vec::new(),
        };
        parser.expression()?;
        let token = parser.peek();
        match token.kind {
            Kind::End => Ok(Syntax {
                nodes: parser.nodes,
            }),
            Kind::Punct(')') => Err(syntax(token.position, "unmatched `)`")),
            _ => Err(syntax(
                token.position,
                "expected an operator (+ - * / ^) or the end",
            )),
        }
    }

    /// The nodes, the root last.
    pub fn nodes(&self) -> &[SyntaxNode] {
        &self.nodes
    }

    /// The names used, each with the byte offset of its first use, in order of appearance.
    pub fn names(&self) -> Vec<(&str, usize)> {
        let mut names: Vec<(&str, usize)> = Vec::new();
        for node in &self.nodes {
            if let SyntaxNode::Name { name, position } = node
                && !names.iter().any(|(n, _)| n == name)
            {
                names.push((name, *position));
            }
        }
        names.sort_by_key(|(_, p)| *p);
        names
    }
}

fn syntax(position: usize, message: impl Into<String>) -> ExprError {
    ExprError::Syntax {
        position,
        message: message.into(),
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Kind {
    Number(f64),
    Name(String),
    /// One of `+ - * / ^ ( ) ,` (`**` is `^`).
    Punct(char),
    End,
}

#[derive(Debug, Clone, PartialEq)]
struct Token {
    kind: Kind,
    position: usize,
}

/// The tokens of `text`, ending with [`Kind::End`] at its length.
fn lex(text: &str) -> Result<Vec<Token>, ExprError> {
    let bytes = text.as_bytes();
    let mut tokens = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let c = bytes[at];
        let start = at;
        let kind = if c.is_ascii_whitespace() {
            at += 1;
            continue;
        } else if c.is_ascii_digit()
            || (c == b'.' && bytes.get(at + 1).is_some_and(u8::is_ascii_digit))
        {
            at = number_end(bytes, at);
            let value: f64 = text[start..at]
                .parse()
                .map_err(|_| syntax(start, "malformed number"))?;
            if !value.is_finite() {
                return Err(syntax(start, "number beyond the range of f64"));
            }
            Kind::Number(value)
        } else if c.is_ascii_alphabetic() || c == b'_' {
            while at < bytes.len() && (bytes[at].is_ascii_alphanumeric() || bytes[at] == b'_') {
                at += 1;
            }
            Kind::Name(text[start..at].to_string())
        } else if c == b'*' && bytes.get(at + 1) == Some(&b'*') {
            at += 2;
            Kind::Punct('^')
        } else if b"+-*/^(),".contains(&c) {
            at += 1;
            Kind::Punct(c as char)
        } else {
            let found = text[start..].chars().next().unwrap_or('?');
            return Err(syntax(start, format!("unexpected character `{found}`")));
        };
        tokens.push(Token {
            kind,
            position: start,
        });
    }
    tokens.push(Token {
        kind: Kind::End,
        position: text.len(),
    });
    Ok(tokens)
}

/// The end of the number starting at `at`: digits, a fraction, an exponent (`e`, a sign,
/// digits; an `e` not followed by digits is not part of the number).
fn number_end(bytes: &[u8], mut at: usize) -> usize {
    let digits = |at: &mut usize| {
        while *at < bytes.len() && bytes[*at].is_ascii_digit() {
            *at += 1;
        }
    };
    digits(&mut at);
    if bytes.get(at) == Some(&b'.') {
        at += 1;
        digits(&mut at);
    }
    if matches!(bytes.get(at), Some(b'e' | b'E')) {
        let mut exponent = at + 1;
        if matches!(bytes.get(exponent), Some(b'+' | b'-')) {
            exponent += 1;
        }
        if bytes.get(exponent).is_some_and(u8::is_ascii_digit) {
            at = exponent;
            digits(&mut at);
        }
    }
    at
}

struct Parser {
    tokens: Vec<Token>,
    at: usize,
    depth: usize,
    nodes: Vec<SyntaxNode>,
}

impl Parser {
    fn peek(&self) -> &Token {
        &self.tokens[self.at.min(self.tokens.len() - 1)]
    }

    fn next(&mut self) -> Token {
        let token = self.peek().clone();
        if self.at < self.tokens.len() - 1 {
            self.at += 1;
        }
        token
    }

    fn is(&self, c: char) -> bool {
        self.peek().kind == Kind::Punct(c)
    }

    fn push(&mut self, node: SyntaxNode, position: usize) -> Result<usize, ExprError> {
        if self.nodes.len() >= MAX_SYNTAX_NODES {
            return Err(ExprError::Limit {
                what: "expression nodes",
                found: self.nodes.len() + 1,
                limit: MAX_SYNTAX_NODES,
                position: Some(position),
            });
        }
        self.nodes.push(node);
        Ok(self.nodes.len() - 1)
    }

    /// expression := term (('+' | '-') term)*
    fn expression(&mut self) -> Result<usize, ExprError> {
        let mut left = self.term()?;
        while self.is('+') || self.is('-') {
            let token = self.next();
            let op = if token.kind == Kind::Punct('+') {
                BinaryOp::Add
            } else {
                BinaryOp::Sub
            };
            let right = self.term()?;
            left = self.push(SyntaxNode::Binary(op, left, right), token.position)?;
        }
        Ok(left)
    }

    /// term := unary (('*' | '/') unary)*
    fn term(&mut self) -> Result<usize, ExprError> {
        let mut left = self.unary()?;
        while self.is('*') || self.is('/') {
            let token = self.next();
            let op = if token.kind == Kind::Punct('*') {
                BinaryOp::Mul
            } else {
                BinaryOp::Div
            };
            let right = self.unary()?;
            left = self.push(SyntaxNode::Binary(op, left, right), token.position)?;
        }
        Ok(left)
    }

    /// unary := ('-' | '+') unary | power
    fn unary(&mut self) -> Result<usize, ExprError> {
        let position = self.peek().position;
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(ExprError::Limit {
                what: "nesting depth",
                found: self.depth,
                limit: MAX_DEPTH,
                position: Some(position),
            });
        }
        let result = if self.is('-') {
            self.next();
            let operand = self.unary()?;
            self.push(SyntaxNode::Neg(operand), position)
        } else if self.is('+') {
            self.next();
            self.unary()
        } else {
            self.power()
        };
        self.depth -= 1;
        result
    }

    /// power := primary ('^' unary)?   (right-associative: a^b^c = a^(b^c), -a^2 = -(a^2))
    fn power(&mut self) -> Result<usize, ExprError> {
        let base = self.primary()?;
        if self.is('^') {
            let token = self.next();
            let exponent = self.unary()?;
            return self.push(
                SyntaxNode::Binary(BinaryOp::Pow, base, exponent),
                token.position,
            );
        }
        Ok(base)
    }

    /// primary := number | name | name '(' arguments ')' | '(' expression ')'
    fn primary(&mut self) -> Result<usize, ExprError> {
        let token = self.next();
        match token.kind {
            Kind::Number(value) => self.push(SyntaxNode::Number(value), token.position),
            Kind::Name(name) if self.is('(') => self.call(name, token.position),
            Kind::Name(name) => {
                if FUNCTIONS.contains(&name.as_str()) {
                    return Err(syntax(
                        token.position,
                        format!("`{name}` is a function: write {name}(...)"),
                    ));
                }
                self.push(
                    SyntaxNode::Name {
                        name,
                        position: token.position,
                    },
                    token.position,
                )
            }
            Kind::Punct('(') => {
                let inner = self.expression()?;
                self.close(token.position)?;
                Ok(inner)
            }
            Kind::End => Err(syntax(token.position, "expected an operand, found the end")),
            Kind::Punct(_) => Err(syntax(token.position, "expected an operand")),
        }
    }

    /// Consumes the `)` closing the `(` at `open`.
    fn close(&mut self, open: usize) -> Result<(), ExprError> {
        if self.is(')') {
            self.next();
            return Ok(());
        }
        let token = self.peek();
        let message = if token.kind == Kind::End {
            format!("expected `)` to close the `(` at byte {open}, found the end")
        } else {
            format!("expected an operator or `)` to close the `(` at byte {open}")
        };
        Err(syntax(token.position, message))
    }

    /// A call of `name` at `position`, the `(` next.
    fn call(&mut self, name: String, position: usize) -> Result<usize, ExprError> {
        let open = self.next().position;
        let mut args = Vec::new();
        if !self.is(')') {
            args.push(self.expression()?);
            while self.is(',') {
                self.next();
                args.push(self.expression()?);
            }
        }
        self.close(open)?;
        let arity = |expected: usize| {
            if args.len() == expected {
                Ok(())
            } else {
                Err(ExprError::Arity {
                    name: name.clone(),
                    position,
                    expected,
                    found: args.len(),
                })
            }
        };
        let node = if name == "atan2" {
            arity(2)?;
            SyntaxNode::Atan2(args[0], args[1])
        } else if let Some(func) = Func::from_name(&name) {
            arity(1)?;
            SyntaxNode::Call(func, args[0])
        } else {
            return Err(ExprError::UnknownFunction {
                name,
                position,
                known: FUNCTIONS.join(", "),
            });
        };
        self.push(node, position)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_lex_with_fractions_and_exponents() {
        for (text, value) in [
            ("1", 1.0),
            ("2.5", 2.5),
            ("1e-3", 1e-3),
            (".5", 0.5),
            ("3.E2", 300.0),
        ] {
            let syntax = Syntax::parse(text).unwrap();
            assert_eq!(syntax.nodes(), [SyntaxNode::Number(value)], "{text}");
        }
    }
}
