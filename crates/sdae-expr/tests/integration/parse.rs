//! Parsing: the grammar's precedence, refusals at their byte positions with carets, unknown
//! names named, the limits.

use sdae_expr::{
    ExprError, Graph, MAX_DEPTH, MAX_SYNTAX_NODES, MAX_TEXT_BYTES, SymbolTable, Syntax,
};

use crate::{table, values};

/// The value of `text` at x = 3, y = -2.
fn value(text: &str) -> f64 {
    let table = table(&["x", "y"], &[("g", 9.81)]);
    let mut graph = Graph::new();
    let e = graph
        .parse(text, &table)
        .unwrap_or_else(|e| panic!("{text}: {e}"));
    values(&graph, &[e], &[&[3.0, -2.0]])[0]
}

#[test]
fn precedence_and_associativity_follow_the_grammar() {
    let cases = [
        ("-x^2", -9.0),
        ("2^3^2", 512.0),
        ("2^-1", 0.5),
        ("2**3", 8.0),
        ("1 - 2 - 3", -4.0),
        ("8/4/2", 1.0),
        ("x - -y", 1.0),
        ("+x*(y + 1)", -3.0),
        ("2.5e1 + .5 + 1E-1", 25.6),
        ("g*(x + y)", 9.81),
        ("atan2(0, -1) - pi", 0.0),
        ("abs(y)*sign(y) + sqrt(x^2 + 16)", 3.0),
        ("x^y", 1.0 / 9.0),
    ];
    for (text, expected) in cases {
        assert_eq!(value(text), expected, "{text}");
    }
}

#[test]
fn syntax_errors_name_their_byte_position() {
    let cases: [(&str, usize, &str); 13] = [
        ("x + * y", 4, "expected an operand"),
        ("x +", 3, "expected an operand, found the end"),
        ("", 0, "expected an operand, found the end"),
        (
            "(x + y",
            6,
            "expected `)` to close the `(` at byte 0, found the end",
        ),
        ("sin(x", 5, "expected `)` to close the `(` at byte 3"),
        ("x y", 2, "expected an operator"),
        ("2x", 1, "expected an operator"),
        ("x + y)", 5, "unmatched `)`"),
        ("x # y", 2, "unexpected character `#`"),
        ("sin x", 0, "`sin` is a function"),
        ("1e999 * x", 0, "beyond the range of f64"),
        ("x * ()", 5, "expected an operand"),
        ("atan2(x,)", 8, "expected an operand"),
    ];
    for (text, position, message) in cases {
        let error = Syntax::parse(text).expect_err(text);
        assert_eq!(error.position(), Some(position), "{text}: {error}");
        assert!(error.to_string().contains(message), "{text}: {error}");
    }
}

#[test]
fn the_caret_stands_under_the_error() {
    let text = "x1 + * y1";
    let error = Syntax::parse(text).unwrap_err();
    assert_eq!(error.caret(text), "x1 + * y1\n     ^ expected an operand");
    assert_eq!(error.to_string(), "at byte 5: expected an operand");
    // Characters, not bytes, before the caret.
    let text = "θ + x";
    let error = Syntax::parse(text).unwrap_err();
    assert_eq!(error.position(), Some(0));
    let text = "x + é";
    let error = Syntax::parse(text).unwrap_err();
    assert_eq!(error.caret(text), "x + é\n    ^ unexpected character `é`");
}

#[test]
fn functions_are_checked_by_name_and_arity() {
    match Syntax::parse("1 + foo(x)").unwrap_err() {
        ExprError::UnknownFunction {
            name,
            position,
            known,
        } => {
            assert_eq!((name.as_str(), position), ("foo", 4));
            assert!(known.contains("atan2") && known.contains("tanh"));
        }
        other => panic!("{other}"),
    }
    for (text, expected, found) in [("atan2(x)", 2, 1), ("sin(x, y)", 1, 2), ("exp()", 1, 0)] {
        match Syntax::parse(text).unwrap_err() {
            ExprError::Arity {
                expected: e,
                found: f,
                position: 0,
                ..
            } => assert_eq!((e, f), (expected, found), "{text}"),
            other => panic!("{text}: {other}"),
        }
    }
}

#[test]
fn unknown_symbols_are_refused_by_name() {
    let table = table(&["x1", "y1", "x2", "y2"], &[("L1", 1.0)]);
    let mut graph = Graph::new();
    let text = "x1^2 + y1^2 - L2^2";
    let error = graph.parse(text, &table).unwrap_err();
    assert_eq!(
        error,
        ExprError::UnknownSymbol {
            name: "L2".into(),
            position: 14,
            hint: "; did you mean `L1`?".into(),
        }
    );
    assert_eq!(
        error.caret(text),
        "x1^2 + y1^2 - L2^2\n              ^ unknown symbol `L2`; did you mean `L1`?"
    );
    match graph.parse("speed * 2", &table).unwrap_err() {
        ExprError::UnknownSymbol { name, hint, .. } => {
            assert_eq!((name.as_str(), hint.as_str()), ("speed", ""))
        }
        other => panic!("{other}"),
    }
    // Unbound, the names are listed with their first positions.
    let syntax = Syntax::parse("a*b + a - c").unwrap();
    assert_eq!(syntax.names(), [("a", 0), ("b", 2), ("c", 10)]);
}

#[test]
fn tables_refuse_bad_names_and_values() {
    let mut table = SymbolTable::new();
    table.add_inputs(&["x"]).unwrap();
    for name in ["sin", "pi", "atan2", "1x", "x-y", "", "x"] {
        assert!(
            matches!(
                table.add_parameter(name, 1.0),
                Err(ExprError::BadSymbol { .. })
            ),
            "{name}"
        );
    }
    assert!(matches!(
        table.add_parameter("k", f64::NAN),
        Err(ExprError::NonFiniteParameter { .. })
    ));
    assert!(table.add_inputs(&["v", "v"]).is_err());
}

#[test]
fn sizes_beyond_the_limits_are_refused() {
    let long = "x + ".repeat(MAX_TEXT_BYTES / 4) + "x";
    let limit = |r: Result<Syntax, ExprError>| match r {
        Err(ExprError::Limit { what, limit, .. }) => (what, limit),
        other => panic!("{other:?}"),
    };
    assert_eq!(
        limit(Syntax::parse(&long)),
        ("expression text bytes", MAX_TEXT_BYTES)
    );
    let deep = "(".repeat(MAX_DEPTH + 1) + "x" + &")".repeat(MAX_DEPTH + 1);
    assert_eq!(limit(Syntax::parse(&deep)), ("nesting depth", MAX_DEPTH));
    let depth_ok = "(".repeat(MAX_DEPTH - 1) + "x" + &")".repeat(MAX_DEPTH - 1);
    assert!(Syntax::parse(&depth_ok).is_ok());
    let wide = "x+".repeat(MAX_SYNTAX_NODES / 2) + "x";
    assert_eq!(
        limit(Syntax::parse(&wide)),
        ("expression nodes", MAX_SYNTAX_NODES)
    );
}

#[test]
fn parameters_fold_into_constants_and_display_parses_back() {
    let table = table(&["x", "y"], &[("L", 1.5), ("g", 9.81)]);
    let mut graph = Graph::new();
    let e = graph.parse("L^2 + 2*L*g", &table).unwrap();
    assert_eq!(graph.constant(e), Some(1.5 * 1.5 + 2.0 * 1.5 * 9.81));
    let names = |v: sdae_expr::Var| ["x", "y"][v.index as usize].to_string();
    for text in [
        "-x^2 - (y - x)/(x*y)^3",
        "x^-2 + 2^(x - y) - -y",
        "atan2(-x, y)*exp(-(x + y))",
    ] {
        let e = graph.parse(text, &table).unwrap();
        let shown = graph.display(e, &names);
        let again = graph.parse(&shown, &table).unwrap();
        let point: &[f64] = &[0.7, -1.3];
        let (a, b) = (
            values(&graph, &[e], &[point])[0],
            values(&graph, &[again], &[point])[0],
        );
        assert_eq!(a.to_bits(), b.to_bits(), "{text} shown as {shown}");
    }
}
