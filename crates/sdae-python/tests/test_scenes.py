"""Scenes from Python: by name, from TOML, files and dicts, refused as the command line refuses
them."""

import subprocess

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
    run = subprocess.run(
        [command_line, "trace", "--scene-file", str(bad), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
    )
    assert run.returncode != 0
    assert key in str(from_file.value)
    assert str(from_file.value) in run.stderr


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
