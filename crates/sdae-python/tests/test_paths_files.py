"""Paths to and from files and pickles: `.npz` files that read back to equal paths and that
numpy reads without pickled objects, pickles, files of something else refused with a
ValueError naming the file and what is wrong, and the XYZ and VTK trajectory files, read back
with numpy and the standard library's XML parser."""

import copy
import json
import os
import pathlib
import pickle
from xml.etree import ElementTree

import numpy as np
import pytest

import sdae


@pytest.fixture(scope="module")
def failed():
    """Paths of which some failed: NaN after their last step, and a message each."""
    paths = sdae.simulate(
        "noisy-pendulum", "half-explicit-untruncated", paths=64, steps=16, seed=1, every=3
    )
    assert 0 < sum(f is not None for f in paths.failures) < 64
    return paths


@pytest.fixture(scope="module")
def fiber():
    """A fiber of 20 beads in 3-D whose paths all end (h = T / 400)."""
    paths = sdae.simulate("fiber", "half-explicit-practical", paths=3, steps=400, seed=2**64 - 1, every=100)
    assert paths.failures == [None] * 3
    return paths


@pytest.fixture(scope="module")
def broken_fiber():
    """A fiber with h = T / 100: one path's kappa system has no root before T."""
    paths = sdae.simulate("fiber", "half-explicit-practical", paths=3, steps=100, seed=2**64 - 1, every=25)
    assert sum(f is not None for f in paths.failures) == 1
    return paths


def assert_same(loaded, paths):
    """Every field of `loaded` is `paths`'s, read-only arrays of the same dtype included."""
    assert loaded == paths
    assert (loaded.scheme, loaded.h, loaded.seed, loaded.steps, loaded.every) == (
        paths.scheme,
        paths.h,
        paths.seed,
        paths.steps,
        paths.every,
    )
    assert loaded.scene == paths.scene
    assert loaded.scene.to_toml() == paths.scene.to_toml()
    assert loaded.failures == paths.failures
    for name in ("times", "positions", "velocities", "multipliers"):
        mine, theirs = getattr(loaded, name), getattr(paths, name)
        assert mine.dtype == theirs.dtype == np.float64
        assert mine.shape == theirs.shape
        assert mine.flags["C_CONTIGUOUS"] and not mine.flags["WRITEABLE"]
        # Bit for bit, NaN included.
        np.testing.assert_array_equal(mine.view(np.uint64), theirs.view(np.uint64))
    assert loaded.diagnostics.keys() == paths.diagnostics.keys()
    for name, column in paths.diagnostics.items():
        assert loaded.diagnostics[name].dtype == column.dtype
        np.testing.assert_array_equal(loaded.diagnostics[name], column)
    assert repr(loaded) == repr(paths)


@pytest.mark.parametrize("which", ["failed", "fiber", "broken_fiber"])
def test_saved_paths_load_back_equal(which, request, tmp_path):
    paths = request.getfixturevalue(which)
    file = tmp_path / "paths.npz"
    assert paths.save(file) is None
    assert_same(sdae.Paths.load(file), paths)
    assert_same(sdae.load_paths(str(file)), paths)


def test_the_file_is_numpys_without_pickles(failed, tmp_path):
    file = tmp_path / "paths.npz"
    failed.save(file)
    with np.load(file, allow_pickle=False) as npz:
        np.testing.assert_array_equal(npz["positions"], failed.positions)
        np.testing.assert_array_equal(npz["times"], failed.times)
        np.testing.assert_array_equal(npz["diagnostics.steps"], failed.diagnostics["steps"])
        meta = json.loads(npz["meta"].item())
    assert meta["seed"] == 1 and meta["steps"] == 16 and meta["every"] == 3
    assert meta["scheme"] == "half-explicit-untruncated"
    assert meta["failures"] == failed.failures
    assert sdae.Scene.from_toml(meta["scene"]) == failed.scene


def test_the_file_has_the_name_given(fiber, tmp_path):
    fiber.save(tmp_path / "run.data")
    assert [p.name for p in tmp_path.iterdir()] == ["run.data"]
    assert sdae.load_paths(tmp_path / "run.data") == fiber


def test_paths_of_another_run_are_not_equal(fiber):
    other = sdae.simulate("fiber", "half-explicit-practical", paths=3, steps=400, seed=3, every=100)
    assert other != fiber
    assert fiber == fiber
    assert fiber != "paths"
    # Equal arrays, another stride in the record: T differs, so not equal either.
    assert sdae.simulate("pendulum", paths=2, steps=8, every=8) != sdae.simulate(
        "pendulum", paths=2, steps=8, every=4
    )


@pytest.mark.parametrize("protocol", [2, pickle.HIGHEST_PROTOCOL])
def test_paths_pickle(failed, protocol):
    assert_same(pickle.loads(pickle.dumps(failed, protocol=protocol)), failed)


def test_paths_copy(fiber):
    assert_same(copy.deepcopy(fiber), fiber)
    assert_same(copy.copy(fiber), fiber)


def test_a_path_that_cannot_be_written_is_an_os_error(fiber, tmp_path):
    with pytest.raises(OSError, match="missing"):
        fiber.save(tmp_path / "missing" / "paths.npz")


def test_a_missing_file_is_an_os_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        sdae.load_paths(tmp_path / "none.npz")


def refused(file, *fragments):
    """Loading `file` raises ValueError naming it and each fragment."""
    with pytest.raises(ValueError) as error:
        sdae.load_paths(file)
    message = str(error.value)
    assert str(file) in message and "not paths written by Paths.save" in message, message
    for fragment in fragments:
        assert fragment in message, message
    return message


def test_a_file_that_is_not_npz_is_a_value_error(tmp_path):
    text = tmp_path / "paths.npz"
    text.write_text("t,x\n0,1\n")
    refused(text, "not a .npz archive", "it starts with \"t,x\\n\"")
    array = tmp_path / "array.npy"
    np.save(array, np.zeros(3))
    refused(array, "not a .npz archive")
    empty = tmp_path / "empty.npz"
    empty.write_bytes(b"")
    refused(empty, "not a .npz archive")


def test_a_cut_file_is_a_value_error(failed, tmp_path):
    file = tmp_path / "paths.npz"
    failed.save(file)
    data = file.read_bytes()
    for cut in (len(data) // 2, len(data) - 10, 40):
        cut_file = tmp_path / f"cut-{cut}.npz"
        cut_file.write_bytes(data[:cut])
        refused(cut_file)


def rewritten(paths, tmp_path, change):
    """The file of `paths` with its entries changed by `change(dict)`."""
    file = tmp_path / "paths.npz"
    paths.save(file)
    with np.load(file) as npz:
        state = dict(npz)
    state["meta"] = json.loads(state["meta"].item())
    change(state)
    if isinstance(state.get("meta"), dict):
        state["meta"] = json.dumps(state["meta"])
    out = tmp_path / "changed.npz"
    np.savez(out, **state)
    return out


def drop(key):
    return lambda state: state.pop(key)


def setting(key, value):
    def change(state):
        state[key] = value

    return change


def meta(key, value):
    def change(state):
        state["meta"][key] = value

    return change


@pytest.mark.parametrize(
    "change, fragments",
    [
        (drop("meta"), ["meta: missing"]),
        (drop("positions"), ["positions: missing"]),
        (drop("diagnostics.clock_lag"), ["diagnostics.clock_lag: missing"]),
        (setting("meta", "{"), ["meta: EOF"]),
        (meta("format", "other"), ["format is not"]),
        (meta("version", 2), ["version 2: this sdae reads version 1"]),
        (meta("scheme", "leapfrog"), ['scheme "leapfrog" is not a built-in scheme']),
        (meta("seed", -1), ["no whole number `seed`"]),
        (meta("h", 0.0), ["no positive step `h`"]),
        (meta("scene", "name = 3"), ["meta.scene"]),
        (meta("failures", [None] * 3), ["positions: shape [64, 7, 2], expected [3, 7, 2]"]),
        (meta("failures", [1] * 64), ["failure 1: not a text or null"]),
        (meta("every", 4), ["times: 7 times, but 16 steps recorded every 4 make 5"]),
        (setting("positions", np.zeros((64, 7, 3))), ["velocities: shape [64, 7, 2], expected [64, 7, 3]"]),
        (setting("velocities", np.zeros((64, 7))), ["velocities: 2 dimensions, expected 3"]),
        (setting("times", np.arange(7)), ["times: not a float64 array (int64 of shape [7])"]),
        (setting("multipliers", np.zeros((64, 7, 1), np.float32)), ["multipliers: not a float64"]),
        (setting("diagnostics.steps", np.zeros(64)), ["diagnostics.steps: not a 1-D uint64 array"]),
        (setting("diagnostics.min_eta", np.zeros(63)), ["diagnostics.min_eta: not a 1-D float64 array of length 64"]),
    ],
)
def test_a_file_of_something_else_is_a_value_error_naming_what(failed, tmp_path, change, fragments):
    refused(rewritten(failed, tmp_path, change), *fragments)


def test_a_file_of_pickled_objects_is_refused_without_reading_them(failed, tmp_path):
    file = rewritten(failed, tmp_path, setting("times", np.array([object()] * 7)))
    refused(file, "pickled")


def test_a_wrong_state_is_a_value_error():
    with pytest.raises(ValueError, match="meta: missing"):
        sdae.Paths._from_state({})


def xyz_frames(file):
    """The frames of an extended XYZ file, read with numpy: (comment fields, (count, 6) array of
    x, y, z, v_x, v_y, v_z) per frame."""
    lines = file.read_text().splitlines()
    frames, at = [], 0
    while at < len(lines):
        count = int(lines[at])
        fields = dict(item.split("=", 1) for item in lines[at + 1].split())
        rows = [line.split() for line in lines[at + 2 : at + 2 + count]]
        assert all(row[0] == "X" for row in rows)
        frames.append((fields, np.array([row[1:] for row in rows], dtype=np.float64)))
        at += 2 + count
    return frames


def points(state, dim):
    """A state of n coordinates as (n / dim, 3) points, z = 0 for a planar system."""
    out = np.zeros((len(state) // dim, 3))
    out[:, :dim] = state.reshape(-1, dim)
    return out


@pytest.mark.parametrize("which, dim", [("failed", 2), ("fiber", 3), ("broken_fiber", 3)])
def test_xyz_files_hold_the_simulated_states(which, dim, request, tmp_path):
    paths = request.getfixturevalue(which)
    files = paths.to_xyz(tmp_path / "xyz")
    name = paths.scene.name
    assert [os.fspath(f) for f in files] == [
        os.fspath(tmp_path / "xyz" / f"{name}.path-{p}.xyz") for p in range(len(paths.failures))
    ]
    for p, file in enumerate(files):
        frames = xyz_frames(pathlib.Path(file))
        finite = np.isfinite(paths.positions[p]).all(axis=1)
        # A failed path's NaN states are left out; the others are there with every digit.
        assert len(frames) == finite.sum() and finite[: len(frames)].all()
        for j, (fields, rows) in enumerate(frames):
            assert float(fields["time"]) == paths.times[j]
            assert (int(fields["step"]), int(fields["path"])) == (round(paths.times[j] / paths.h), p)
            assert fields["scheme"] == paths.scheme
            np.testing.assert_array_equal(rows[:, :3], points(paths.positions[p, j], dim))
            np.testing.assert_array_equal(rows[:, 3:], points(paths.velocities[p, j], dim))


@pytest.mark.parametrize("which", ["fiber", "broken_fiber"])
def test_vtk_files_hold_the_simulated_states(which, request, tmp_path):
    paths = request.getfixturevalue(which)
    files = paths.to_vtk(tmp_path / "vtk")
    collection = ElementTree.parse(files[0]).getroot()
    sets = collection.findall("./Collection/DataSet")
    assert [float(s.get("timestep")) for s in sets] == list(paths.times)
    assert [os.fspath(tmp_path / "vtk" / s.get("file")) for s in sets] == [os.fspath(f) for f in files[1:]]
    beads = paths.positions.shape[2] // 3
    for j, data_set in enumerate(sets):
        grid = ElementTree.parse(tmp_path / "vtk" / data_set.get("file")).getroot()

        def array(name):
            found = [a for a in grid.iter("DataArray") if a.get("Name") == name]
            return np.array(found[0].text.split(), dtype=np.float64)

        # One polyline per path with a state at this time (a failed path's NaN left out).
        alive = np.flatnonzero(np.isfinite(paths.positions[:, j]).all(axis=1))
        np.testing.assert_array_equal(array("path"), alive)
        np.testing.assert_array_equal(array("offsets"), beads * np.arange(1, len(alive) + 1))
        shape = (len(alive), beads, 3)
        np.testing.assert_array_equal(array("position").reshape(shape), paths.positions[alive, j].reshape(shape))
        np.testing.assert_array_equal(array("velocity").reshape(shape), paths.velocities[alive, j].reshape(shape))
    if which == "broken_fiber":
        assert len(alive) == 2


def test_vtk_of_a_scene_without_a_chain_is_a_value_error(failed, tmp_path):
    with pytest.raises(ValueError, match="vtk"):
        failed.to_vtk(tmp_path)


def test_trajectories_of_loaded_paths_are_the_same_files(fiber, tmp_path):
    fiber.save(tmp_path / "fiber.npz")
    loaded = sdae.load_paths(tmp_path / "fiber.npz")
    for write in ("to_xyz", "to_vtk"):
        mine = getattr(fiber, write)(tmp_path / "a" / write)
        theirs = getattr(loaded, write)(tmp_path / "b" / write)
        assert [pathlib.Path(f).read_bytes() for f in mine] == [pathlib.Path(f).read_bytes() for f in theirs]


def test_a_folder_that_cannot_be_made_is_an_os_error(fiber, tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(OSError):
        fiber.to_xyz(tmp_path / "file" / "xyz")
