"""Scenes from Python: by name, from TOML, files and dicts, refused as the command line refuses
them."""

import re
import subprocess

import numpy as np
import pytest

import sdae


def test_every_built_in_scene_loads_and_reads_back_from_its_dict_and_its_toml():
    assert "pendulum" in sdae.built_in_scenes()
    for name in sdae.built_in_scenes():
        scene = sdae.scene(name)
        assert scene.name == name
        assert sdae.Scene.from_dict(scene.to_dict()) == scene
        assert sdae.Scene.from_toml(scene.to_toml()) == scene


def test_a_scene_file_is_read_by_path(tmp_path):
    path = tmp_path / "mine.toml"
    table = sdae.scene("pendulum").to_dict()
    table["name"] = "mine"
    path.write_text(sdae.Scene.from_dict(table).to_toml())
    assert sdae.scene(path).name == "mine"
    assert sdae.scene(str(path)).name == "mine"


def test_an_unknown_name_is_a_value_error_listing_the_built_in_ones():
    with pytest.raises(ValueError, match="no built-in scene 'nowhere'.*pendulum"):
        sdae.scene("nowhere")


def test_a_missing_file_is_an_os_error_naming_it(tmp_path):
    missing = tmp_path / "missing.toml"
    for source in (missing, str(missing)):
        with pytest.raises(OSError, match="missing.toml"):
            sdae.scene(source)


def test_a_scene_of_another_type_is_a_type_error():
    with pytest.raises(TypeError, match="not int"):
        sdae.scene(3)


@pytest.mark.parametrize(
    "change, key",
    [
        (lambda t: t.update(T=-1.0), "T"),
        (lambda t: t.update(colour="red"), "colour"),
        (lambda t: t["study"].update(levels=[10, 3]), "study.levels"),
    ],
)
def test_a_refused_dict_raises_the_command_lines_message(tmp_path, command_line, change, key):
    table = sdae.scene("pendulum").to_dict()
    change(table)
    with pytest.raises(ValueError) as refused:
        sdae.Scene.from_dict(table)
    assert key in str(refused.value)
    # The same scene as a file: refused with the message the command line prints for it, word for
    # word, which names the same key.
    bad = tmp_path / "bad.toml"
    bad.write_text(_toml(table))
    with pytest.raises(ValueError) as from_file:
        sdae.Scene.from_file(bad)
    stderr = _refused_by_the_command_line(command_line, bad, tmp_path)
    assert key in str(from_file.value)
    assert str(from_file.value) in stderr


def _refused_by_the_command_line(command_line, scene_file, tmp_path):
    """What the command line prints on stderr for a trace of ``scene_file``, which it must
    refuse (a nonzero exit code)."""
    run = subprocess.run(
        [command_line, "trace", "--scene-file", str(scene_file), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
    )
    assert run.returncode != 0
    return run.stderr


def _toml(table, prefix=""):
    """A small TOML writer for the scene tables of these tests (numbers, strings, lists)."""
    lines, tables = [], []
    for k, v in table.items():
        if isinstance(v, dict):
            tables.append((k, v))
        else:
            lines.append(f"{k} = {_value(v)}")
    text = "\n".join(lines) + "\n"
    for k, v in tables:
        name = f"{prefix}{k}"
        text += f"[{name}]\n" + _toml(v, name + ".")
    return text


def _value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else str(v)


def test_the_packages_docstring_examples_run():
    import doctest

    failures, tried = doctest.testmod(sdae)
    assert tried > 0
    assert failures == 0


def test_a_scene_pickles_to_an_equal_scene():
    import pickle

    for name in ("pendulum", "triatomic", "fiber"):
        scene = sdae.scene(name)
        assert pickle.loads(pickle.dumps(scene)) == scene


def _pendulum(change):
    """The pendulum scene's dict with `change` made to it."""
    table = sdae.scene("pendulum").to_dict()
    change(table)
    return table


def test_a_scene_dict_takes_numpy_scalars_and_arrays():
    def numpy(t):
        t["T"] = np.float32(1.0)
        t["study"]["paths"] = np.int64(10000)
        t["study"]["levels"] = np.array([3, 10])
        t["system"]["pendulum"]["length"] = np.float64(1.0)
        t["initial"]["position"] = np.array([0.0, -1.0])
        t["initial"]["velocity"] = (np.float64(1.0), 0)
        t["initial"]["project"] = np.bool_(False)

    assert sdae.scene(_pendulum(numpy)) == sdae.scene("pendulum")


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda t: t["system"]["pendulum"].update(length=float("nan")),
            "system.pendulum.length = nan: must be finite",
        ),
        (
            lambda t: t["system"]["pendulum"].update(gravity=np.float64("inf")),
            "system.pendulum.gravity = inf: must be finite",
        ),
        (
            lambda t: t["initial"].update(velocity=np.array([1.0, -np.inf])),
            "initial.velocity[1] = -inf: must be finite",
        ),
        (lambda t: t.update(T=float("nan")), "T = nan: must be finite"),
    ],
)
def test_nan_or_infinity_in_a_scene_dict_is_refused_naming_its_key(change, message):
    with pytest.raises(ValueError) as refused:
        sdae.scene(_pendulum(change))
    assert str(refused.value).startswith(message), str(refused.value)


@pytest.mark.parametrize(
    "change, error, message",
    [
        (
            lambda t: t["system"]["pendulum"].update(length="1.0"),
            ValueError,
            'system.pendulum.length: invalid type: string "1.0", expected f64',
        ),
        (lambda t: t["study"].update(paths=True), ValueError, "study.paths: invalid type: boolean"),
        (lambda t: t["study"].update(paths=-3), ValueError, "study.paths: invalid value: integer `-3`"),
        (lambda t: t["outputs"].append("speed"), ValueError, "outputs[3]: unknown variant `speed`"),
        (lambda t: t["system"]["pendulum"].pop("length"), ValueError, "system.pendulum: missing field `length`"),
        (lambda t: t.update(outputs={"position"}), TypeError, "outputs = {'position'}: a scene holds"),
        (lambda t: t["study"].update({3: 4}), TypeError, "study: a key is a string, not int"),
    ],
)
def test_a_value_of_the_wrong_kind_in_a_scene_dict_is_refused_naming_its_key(change, error, message):
    with pytest.raises(error) as refused:
        sdae.scene(_pendulum(change))
    assert str(refused.value).startswith(message), str(refused.value)


def test_a_scene_dict_that_holds_itself_is_refused():
    table = _pendulum(lambda t: None)
    table["study"]["again"] = table
    with pytest.raises(ValueError, match="study: tables and lists nested more than"):
        sdae.scene(table)


# Values only the system, once built, or the initial state, once checked, refuse.
REFUSED_WHEN_BUILT = [
    (lambda t: t["system"]["pendulum"].update(length=-1.0), "length = -1: must be finite and > 0"),
    (lambda t: t["system"]["pendulum"].update(length=0.0), "length = 0: must be finite and > 0"),
    (lambda t: t["system"]["pendulum"].update(dim=4), "dim = 4: a pendulum is planar (2) or spherical (3)"),
    (lambda t: t["initial"].update(position=[0.5, -1.0]), "initial state: position is off the manifold"),
    (lambda t: t["initial"].update(velocity=[0.0, 1.0]), "initial state: velocity is not tangent"),
]


@pytest.mark.parametrize("change, message", REFUSED_WHEN_BUILT)
def test_a_scene_is_refused_when_made_where_a_run_would_refuse_it(change, message):
    table = _pendulum(change)
    for make in (sdae.scene, sdae.Scene.from_dict):
        with pytest.raises(ValueError, match="^scene pendulum: .*" + re.escape(message)):
            make(table)
    with pytest.raises(ValueError, match=re.escape(message)):
        sdae.Scene.from_toml(_toml(table))


@pytest.mark.parametrize("change, message", REFUSED_WHEN_BUILT[:1] + REFUSED_WHEN_BUILT[3:4])
def test_a_scene_file_is_refused_when_read_as_the_command_line_refuses_it(
    tmp_path, command_line, change, message
):
    bad = tmp_path / "bad.toml"
    bad.write_text(_toml(_pendulum(change)))
    with pytest.raises(ValueError) as refused:
        sdae.scene(bad)
    stderr = _refused_by_the_command_line(command_line, bad, tmp_path)
    assert message in str(refused.value)
    assert str(refused.value) in stderr
