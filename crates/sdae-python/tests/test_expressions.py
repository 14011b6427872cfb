"""Systems written as expressions, from Python: a scene dict's ``system.expressions`` table
(docs/custom-systems.md), simulated and studied as a built-in system is, observables given as
expression strings, and each kind of bad input refused with a ValueError naming its key."""

import pathlib
import re

import numpy as np
import pytest

import sdae

DOCS = pathlib.Path(__file__).resolve().parents[3] / "docs" / "custom-systems.md"


def double_pendulum(**changes):
    """A double pendulum in the plane under gravity with additive noise, as a scene dict, with
    ``changes`` to its ``system.expressions`` table (a value None removes the key)."""
    expressions = {
        "particles": 2,
        "dimension": 2,
        "mass": 1.0,
        "parameters": {"L1": 1.0, "L2": 1.0, "g": 1.0},
        "constraints": ["x1^2 + y1^2 - L1^2", "(x2 - x1)^2 + (y2 - y1)^2 - L2^2"],
        "potential": "g * (y1 + y2)",
        "noise": 0.5,
        "position": [0.6, -0.8, 1.4, -1.4],
        "velocity": [0.8, 0.6, 0.8, 0.6],
        "observables": {"height": "y2"},
    }
    expressions.update(changes)
    expressions = {key: value for key, value in expressions.items() if value is not None}
    return {
        "name": "double",
        "T": 1.0,
        "outputs": ["position", "velocity"],
        "system": {"expressions": expressions},
        "weak": {
            "observables": ["height", "y2", "v_x2^2 + v_y2^2"],
            "paths": 200,
            "levels": [2, 4],
            "reference": 7,
        },
    }


def residuals(positions):
    """|g_1| and |g_2| of the double pendulum at every path and time."""
    x1, y1, x2, y2 = (positions[..., k] for k in range(4))
    return np.abs(x1**2 + y1**2 - 1.0), np.abs((x2 - x1) ** 2 + (y2 - y1) ** 2 - 1.0)


def test_paths_of_a_dict_of_expressions_stay_on_the_manifold():
    paths = sdae.simulate(sdae.scene(double_pendulum()), paths=16, steps=128, seed=3, every=8)
    assert paths.positions.shape == (16, 17, 4)
    assert not paths.failures or all(f is None for f in paths.failures)
    assert np.isfinite(paths.positions).all()
    for g in residuals(paths.positions):
        assert g.max() < 1e-9
    # The paths move: the noise and gravity act.
    assert np.abs(paths.positions[:, -1] - paths.positions[:, 0]).max() > 0.1


def test_the_weak_study_reports_observables_given_by_name_and_as_expressions():
    report = sdae.weak(sdae.scene(double_pendulum()), quick=True, progress=False)
    names = [o["name"] for o in report.to_dict()["observables"]]
    assert names == ["height", "y2", "v_x2^2 + v_y2^2"]
    # `height` is y2 in the spec: the text y2 gives the same numbers.
    rows = {name: [r for r in report.rows if r.get("observable") == name] for name in names}
    assert rows["height"] and len(rows["height"]) == len(rows["y2"])
    for a, b in zip(rows["height"], rows["y2"]):
        assert {k: v for k, v in a.items() if k != "observable"} == {
            k: v for k, v in b.items() if k != "observable"
        }


def test_an_expression_is_an_observable_of_the_expectation_too():
    found = sdae.expectation(
        double_pendulum(), "x2^2 + y2^2", eps=0.1, method="standard", progress=False
    )
    # |r2|^2 is between 0 and (L1 + L2)^2.
    assert 0.0 <= found.value <= 4.0
    with pytest.raises(ValueError, match=r"no observable 'x2\^2 \+ \* y2'") as refused:
        sdae.expectation(double_pendulum(), "x2^2 + * y2", eps=0.1, progress=False)
    caret_under(str(refused.value), "x2^2 + * y2", "x2^2 + ")


def caret_under(message, text, before):
    """Asserts that `message` shows `text` on a line of its own and a caret under the character
    after `before` on the next line."""
    lines = message.splitlines()
    assert text in lines, message
    caret = lines[lines.index(text) + 1]
    assert caret.index("^") == len(before), message


HOSTILE = [
    (
        "parse error",
        {"constraints": ["x1^2 + y1^2 - L1^2", "(x2 - x1)^2 + * (y2 - y1)^2 - L2^2"]},
        ["system.expressions.constraints[1]", "expected an operand"],
    ),
    (
        "unknown symbol",
        {"potential": "gravity * (y1 + y2)"},
        ["system.expressions.potential", "unknown symbol `gravity`"],
    ),
    (
        "rank-deficient Jacobian",
        {"constraints": ["x1^2 + y1^2 - L1^2", "2 * x1^2 + 2 * y1^2 - 2 * L1^2"]},
        ["system.expressions", "rank 1 < 2"],
    ),
    (
        "off the manifold",
        {"position": [0.6, -0.9, 1.4, -1.4]},
        ["system.expressions.position", "|g(r0)|", "project = true"],
    ),
    (
        "too many particles",
        {"particles": 100000, "position": [0.0] * 4},
        ["system.expressions.particles", "beyond the limit of 1024"],
    ),
    (
        "NaN in a parameter",
        {"parameters": {"L1": 1.0, "L2": float("nan"), "g": 1.0}},
        ["system.expressions.parameters.L2 = nan", "must be finite"],
    ),
]


@pytest.mark.parametrize("change, words", [h[1:] for h in HOSTILE], ids=[h[0] for h in HOSTILE])
def test_hostile_inputs_are_refused_naming_the_key(change, words):
    with pytest.raises(ValueError) as refused:
        sdae.scene(double_pendulum(**change))
    message = str(refused.value)
    for word in words:
        assert word in message, message


def test_a_parse_error_shows_the_caret_under_the_text():
    bad = "(x2 - x1)^2 + * (y2 - y1)^2 - L2^2"
    with pytest.raises(ValueError) as refused:
        sdae.scene(double_pendulum(constraints=["x1^2 + y1^2 - L1^2", bad]))
    caret_under(str(refused.value), bad, "(x2 - x1)^2 + ")


def test_a_system_built_in_code_and_an_unknown_kind_point_to_expressions():
    table = double_pendulum()
    table["system"] = {"custom": "mine"}
    with pytest.raises(ValueError, match=r"system\.custom.*system\.expressions"):
        sdae.scene(table)
    table["system"] = {"ellipse": {}}
    with pytest.raises(ValueError, match=r"system\.ellipse: unknown variant.*`expressions`"):
        sdae.scene(table)


def test_the_example_of_the_docs_runs_as_written():
    text = DOCS.read_text()
    section = text[text.index("## From Python") :]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    namespace = {}
    exec(compile(code, str(DOCS), "exec"), namespace)
    paths, report = namespace["paths"], namespace["report"]
    x, y = paths.positions[..., 0], paths.positions[..., 1]
    assert np.abs(x**2 / 4 + y**2 - 1).max() < 1e-9
    names = [o["name"] for o in report.to_dict()["observables"]]
    assert names == ["height", "x^2 - y^2"]
    assert paths.positions.shape == (100, 257, 2)
    # x^2 + y^2 = 1 + 3 x^2 / 4 on the ellipse: from 1 to 4.
    assert 1.0 <= namespace["found"].value <= 4.0
