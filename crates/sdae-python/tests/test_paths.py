"""Simulated paths: the library's numbers for the seed, whatever the threads and the number of
paths; documented shapes and dtypes; refused settings; Ctrl-C."""

import _thread
import csv
import subprocess
import threading
import time

import numpy as np
import pytest

import sdae


def test_arrays_have_the_documented_shapes_and_dtypes():
    paths = sdae.simulate("pendulum", paths=5, steps=100, seed=3, every=30)
    assert paths.times.shape == (5,)
    np.testing.assert_array_equal(paths.times, np.array([0, 30, 60, 90, 100]) * paths.h)
    for array, width in ((paths.positions, 2), (paths.velocities, 2), (paths.multipliers, 1)):
        assert array.shape == (5, 5, width)
        assert array.dtype == np.float64
        assert array.flags["C_CONTIGUOUS"]
    assert paths.failures == [None] * 5
    diagnostics = paths.diagnostics
    assert set(diagnostics) >= {"steps", "min_eta", "max_position_residual", "clock_lag"}
    np.testing.assert_array_equal(diagnostics["steps"], [100] * 5)
    # On the circle at every recorded time, with mu_0 = 0.
    radius = np.linalg.norm(paths.positions, axis=2)
    np.testing.assert_allclose(radius, 1.0, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(paths.multipliers[:, 0, :], 0.0)


def test_a_path_does_not_depend_on_the_threads_or_the_other_paths():
    # Blocks of 64 paths: paths 64..70 sit in a block of 6 on one thread and of 64 on two.
    few = sdae.simulate("pendulum", paths=70, steps=64, seed=11, every=8)
    many = sdae.simulate("pendulum", paths=128, steps=64, seed=11, every=8, threads=2)
    np.testing.assert_array_equal(few.positions, many.positions[:70])
    np.testing.assert_array_equal(few.velocities, many.velocities[:70])
    np.testing.assert_array_equal(few.multipliers, many.multipliers[:70])


def test_the_arrays_are_read_only():
    paths = sdae.simulate("pendulum", paths=2, steps=8)
    with pytest.raises(ValueError, match="read-only"):
        paths.positions[0, 0, 0] = 1.0
    assert paths.positions is paths.positions


def test_path_zero_is_the_command_lines_trace_bit_for_bit(tmp_path, command_line):
    # `trace` runs one path (stream seed, path 0) of the half-explicit scheme with the practical
    # C_eta over 2^k steps, k the scene's finest study level, recording every (2^k // 400)-th
    # step; its CSV holds t and r with every digit.
    subprocess.run(
        [command_line, "trace", "--scene", "pendulum", "--seed", "5", "--out", str(tmp_path)],
        check=True,
        capture_output=True,
    )
    with open(tmp_path / "trace" / "pendulum.csv") as f:
        rows = [[float(x) for x in row] for row in list(csv.reader(f))[1:]]
    scene = sdae.scene("pendulum")
    steps = 2 ** scene.to_dict()["study"]["levels"][1]
    every = max(steps // 400, 1)
    paths = sdae.simulate(scene, "half-explicit-practical", paths=1, steps=steps, seed=5, every=every)
    assert len(rows) >= 400
    for j, (t, *r) in enumerate(rows):
        assert t == pytest.approx(paths.times[j], rel=1e-12)
        np.testing.assert_array_equal(paths.positions[0, j], r)


@pytest.mark.parametrize(
    "settings, name",
    [
        (dict(paths=0, steps=10), "paths"),
        (dict(paths=1, steps=0), "steps"),
        (dict(paths=1, steps=10, every=0), "every"),
        (dict(paths=1, steps=10, threads=0), "threads"),
        (dict(paths=-1, steps=10), "paths = -1"),
        (dict(paths=1, steps=10, seed=-1), "seed = -1"),
        (dict(paths=10**15, steps=10**6), "paths = 1000000000000000: the recorded states need"),
        (dict(paths=1, steps=10, threads=1025), "threads = 1025: must be in 1..=1024"),
    ],
)
def test_a_refused_setting_is_a_value_error_naming_it(settings, name):
    with pytest.raises(ValueError, match=name):
        sdae.simulate("pendulum", **settings)


@pytest.mark.parametrize(
    "settings, message",
    [
        (dict(paths=True, steps=8), "paths = True: must be a whole number, not bool"),
        (dict(paths=2, steps=True), "steps = True: must be a whole number"),
        (dict(paths=2, steps=8, seed=False), "seed = False: must be a whole number"),
        (dict(paths=2, steps=8, every=True), "every = True: must be a whole number"),
        (dict(paths=2, steps=8, threads=True), "threads = True: must be a whole number"),
        (dict(paths=np.bool_(True), steps=8), "paths = np.True_: must be a whole number"),
        (dict(paths="2", steps=8), "paths = '2': must be a whole number, not str"),
        (dict(paths=2.0, steps=8), "paths = 2.0: must be a whole number, not float"),
        (dict(paths=2, steps=8, progress=1), "progress = 1: must be True or False"),
    ],
)
def test_a_bool_string_or_float_where_a_count_goes_is_a_type_error_naming_it(settings, message):
    with pytest.raises(TypeError) as refused:
        sdae.simulate("pendulum", **settings)
    assert message in str(refused.value)


def test_the_scheme_is_one_name():
    with pytest.raises(TypeError, match=r"scheme = \['euler-maruyama'\]: must be a name"):
        sdae.simulate("pendulum", ["euler-maruyama"], paths=1, steps=4)


def test_numpy_integers_are_counts():
    paths = sdae.simulate("pendulum", paths=np.int64(3), steps=np.int32(8), seed=np.uint64(2))
    assert paths.positions.shape == (3, 9, 2)
    np.testing.assert_array_equal(
        paths.positions, sdae.simulate("pendulum", paths=3, steps=8, seed=2).positions
    )


def test_threads_beyond_one_per_path_or_four_per_core_are_not_started():
    # As on the command line: 1000 threads asked for 1000 paths of 16 steps start at most 4
    # per core, and the run takes as long as with a few threads (starting them all took
    # seconds for a run of milliseconds).
    def seconds(threads):
        start = time.monotonic()
        run = sdae.simulate("pendulum", paths=1000, steps=16, seed=4, threads=threads)
        return time.monotonic() - start, run

    few, expected = seconds(2)
    many, run = seconds(1000)
    np.testing.assert_array_equal(run.positions, expected.positions)
    assert many < 5 * few + 0.25, (many, few)


def test_an_unknown_scheme_is_a_value_error_listing_the_schemes():
    with pytest.raises(ValueError, match="g-baoab"):
        sdae.simulate("pendulum", "leapfrog", paths=1, steps=10)


def test_a_scheme_that_does_not_apply_is_a_value_error():
    # BAOAB needs a Langevin system: the pendulum scene's noise is not sigma I with friction.
    if "baoab-rattle" not in sdae.schemes():
        pytest.fail("baoab-rattle is a built-in scheme")
    with pytest.raises(ValueError, match="baoab-rattle does not apply"):
        sdae.simulate("fiber", "baoab-rattle", paths=1, steps=10)


def test_ctrl_c_stops_a_run_within_a_second_and_the_interpreter_goes_on():
    timer = threading.Timer(0.5, _thread.interrupt_main)
    start = time.monotonic()
    timer.start()
    # About 10^9 path-steps, some seconds: a run that ignored the signal would end, and fail
    # this test, instead of hanging.
    with pytest.raises(KeyboardInterrupt):
        sdae.simulate("pendulum", paths=20_000, steps=1 << 16, seed=1, every=1 << 16)
    elapsed = time.monotonic() - start
    timer.cancel()
    assert elapsed < 0.5 + 1.0
    # The interpreter and the package still work.
    assert sdae.simulate("pendulum", paths=1, steps=4).positions.shape == (1, 5, 2)


def test_a_failed_path_holds_nan_after_its_last_completed_step():
    # Untruncated steps of 1/16 on the noisy pendulum: the kappa system of some paths has no
    # root connected to 0.
    paths = sdae.simulate("noisy-pendulum", "half-explicit-untruncated", paths=64, steps=16, seed=1)
    failed = [p for p, failure in enumerate(paths.failures) if failure]
    assert 0 < len(failed) < 64
    for p, failure in enumerate(paths.failures):
        done = paths.diagnostics["steps"][p] if failure else 16
        assert np.isfinite(paths.positions[p, : done + 1]).all()
        assert np.isnan(paths.positions[p, done + 1 :]).all()
        assert np.isnan(paths.multipliers[p, done + 1 :]).all()
    assert all("kappa system" in paths.failures[p] for p in failed)


def test_a_progress_line_is_drawn_on_request_and_cleared(capfd):
    sdae.simulate("pendulum", paths=64, steps=64, progress=False)
    assert capfd.readouterr().err == ""
    sdae.simulate("pendulum", paths=64, steps=64, progress=True)
    err = capfd.readouterr().err
    assert "\rpendulum half-explicit-practical: 0/64 paths, 0.0 s" in err, err
    assert err.endswith("\r")
