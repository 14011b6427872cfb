"""The studies from Python against the command line's reports, exact values and bad input."""

import _thread
import errno
import json
import os
import pathlib
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import sdae

def assert_same_numbers(command_line, tmp_path, first, second):
    """The command line's `compare` finds the numbers of two reports' JSON texts equal
    (it leaves out what differs between runs of one study: timings, threads, checksums)."""
    files = [tmp_path / "first.json", tmp_path / "second.json"]
    for file, text in zip(files, (first, second)):
        file.write_text(text)
    done = subprocess.run(
        [command_line, "compare", *map(str, files)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stdout + done.stderr


def cli_report(command_line, tmp_path, args, file):
    """The JSON report the command line writes for `args` (its output folder under tmp_path)."""
    out = tmp_path / "cli"
    subprocess.run([command_line, *args, "--out", str(out)], check=True, capture_output=True)
    return (out / file).read_text()


# Each study from Python and from the command line with the same options.
SAME_STUDIES = [
    (
        lambda: sdae.convergence("pendulum", paths=12, levels=(3, 5), ref_level=9, threads=2),
        ["convergence", "--scene", "pendulum", "--paths", "12", "--levels", "3..5",
         "--ref-level", "9", "--threads", "1"],
        "pendulum/report.json",
    ),
    (
        lambda: sdae.convergence("noisy-pendulum", quick=True, paths=10, schemes=["euler-maruyama", "half-explicit-practical"], p=1.0),
        ["convergence", "--scene", "noisy-pendulum", "--quick", "--paths", "10",
         "--schemes", "euler-maruyama,half-explicit-practical", "--p", "1"],
        "noisy-pendulum/report.json",
    ),
    (
        lambda: sdae.weak("rotor", quick=True, paths=96),
        ["weak", "--scene", "rotor", "--quick", "--paths", "96"],
        "rotor/weak.json",
    ),
    (
        lambda: sdae.weak("pendulum", quick=True, qmc=True, randomizations=4, paths=64),
        ["weak", "--scene", "pendulum", "--quick", "--qmc", "--randomizations", "4",
         "--paths", "64"],
        "pendulum/weak.json",
    ),
    (
        lambda: sdae.stability("stiff-fiber", quick=True, paths=4),
        ["stability", "--scene", "stiff-fiber", "--quick", "--paths", "4"],
        "stability/report.json",
    ),
    (
        lambda: sdae.mlmc("pendulum", quick=True, eps=[0.05, 0.03], seed=7),
        ["mlmc", "--scene", "pendulum", "--quick", "--eps", "0.05,0.03", "--seed", "7"],
        "mlmc/pendulum/report.json",
    ),
]


@pytest.mark.parametrize("study, args, file", SAME_STUDIES)
def test_a_report_equals_the_command_lines_json(tmp_path, command_line, study, args, file):
    report = study()
    expected = cli_report(command_line, tmp_path, args, file)
    assert_same_numbers(command_line, tmp_path, report.to_json(), expected)


def test_the_rows_are_the_command_lines_csv(tmp_path, command_line):
    report = sdae.convergence("pendulum", paths=12, levels=(3, 5), ref_level=9, progress=False)
    out = tmp_path / "cli"
    subprocess.run(
        [command_line, "convergence", "--scene", "pendulum", "--paths", "12", "--levels", "3..5",
         "--ref-level", "9", "--out", str(out)],
        check=True,
        capture_output=True,
    )
    lines = (out / "pendulum" / "report.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert list(report.rows[0]) == header
    assert len(report.rows) == len(lines) - 1
    for row, line in zip(report.rows, lines[1:]):
        for column, cell in zip(header, line.split(",")):
            if column not in ("seconds_per_path", "steps_per_second") and cell:
                assert str(row[column]) == cell or float(row[column]) == float(cell), column


def test_report_fields_are_numbers_lists_and_arrays(tmp_path):
    report = sdae.mlmc("pendulum", quick=True, eps=[0.05], standard=False, progress=False)
    assert report.kind == "mlmc"
    assert isinstance(report.to_dict()["settings"]["seed"], int)
    eps = report.settings["spec"]["eps"]
    assert isinstance(eps, np.ndarray) and eps.dtype == np.float64 and list(eps) == [0.05]
    levels = report.test
    assert isinstance(levels, list) and isinstance(levels[0]["var_y"], float)
    assert report.standard is None
    assert [row["level"] for row in report.rows] == [level["level"] for level in levels]
    assert report.tables[1][0]["eps"] == 0.05
    with pytest.raises(AttributeError, match="no field 'schemes'"):
        report.schemes
    report.write(tmp_path / "out")
    written = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert written == ["cost.svg", "levels.svg", "report.csv", "report.json", "report.md", "samples.svg"]
    assert json.loads((tmp_path / "out" / "report.json").read_text())["scene"] == "pendulum"
    assert "pendulum" in report.markdown


def test_the_expectation_covers_the_rotors_closed_form():
    # E[cos(phi_T - phi_0)] of the rotor, in closed form (its scene file's [weak] table).
    exact = 0.7417415778265619
    found = sdae.expectation("rotor", "cos_turn", eps=1e-2, seed=3, progress=False)
    low, high = found.interval
    assert low <= exact <= high, (found.interval, found.bias)
    s_low, s_high = found.sampling_interval
    assert low == s_low - found.bias and high == s_high + found.bias
    # The pilot's predicted work of each estimator: the cheapest offered one ran.
    offered = [p for p in found.predicted if p["offered"]]
    assert {p["method"] for p in found.predicted} == {"mlmc", "mlqmc", "standard", "rqmc"}
    assert found.method == min(offered, key=lambda p: p["work"])["method"]
    assert found.to_dict()["observable"] == "cos_turn"
    assert "E[cos_turn(X_T)] of rotor" in repr(found)


def test_expectations_do_not_depend_on_the_threads(tmp_path, command_line):
    one = sdae.expectation("pendulum", eps=5e-2, threads=1, progress=False)
    two = sdae.expectation("pendulum", eps=5e-2, threads=2, progress=False)
    assert_same_numbers(command_line, tmp_path, one.to_json(), two.to_json())
    changed = sdae.expectation("pendulum", eps=5e-2, seed=1, progress=False)
    with pytest.raises(AssertionError):
        assert_same_numbers(command_line, tmp_path, one.to_json(), changed.to_json())


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: sdae.convergence("pendulum", paths=0), "paths = 0"),
        (lambda: sdae.convergence("pendulum", paths=-3), "paths = -3"),
        (lambda: sdae.convergence("pendulum", levels=(5, 3)), "levels = (5, 3)"),
        (lambda: sdae.convergence("pendulum", schemes=["nope"]), "schemes = \"nope\""),
        (lambda: sdae.convergence("pendulum", reference_scheme="nope"), "reference_scheme"),
        (lambda: sdae.convergence("pendulum", threads=0), "threads = 0"),
        (lambda: sdae.convergence("pendulum", threads=1025), "threads = 1025: must be in 1..=1024"),
        (lambda: sdae.convergence("pendulum", t_end=-1.0), "t_end = -1"),
        (lambda: sdae.weak("fiber"), "has no [weak] table"),
        (lambda: sdae.weak("pendulum", randomizations=4), "randomizations = 4: needs qmc=True"),
        (lambda: sdae.weak("pendulum", qmc=True, randomizations=1), "randomizations = 1"),
        (lambda: sdae.stability("pendulum"), "has no [stability] table"),
        (lambda: sdae.mlmc("pendulum", eps=[-1.0]), "eps = -1"),
        (lambda: sdae.mlmc("pendulum", observable="cos_angel"), "cos_angel"),
        (lambda: sdae.mlmc("pendulum", test_samples=-1), "test_samples = -1"),
        (lambda: sdae.expectation("pendulum", eps=0.0), "eps"),
        (lambda: sdae.expectation("pendulum", eps=1e-2, test_levels=1), "levels"),
    ],
)
def test_a_refused_setting_is_a_value_error_naming_it(call, name):
    with pytest.raises(ValueError) as refused:
        call()
    assert name in str(refused.value)


@pytest.mark.parametrize(
    "schemes, expected",
    [
        ("half-explicit-practical", ["half-explicit-practical"]),
        ("euler-maruyama, half-explicit-practical", ["euler-maruyama", "half-explicit-practical"]),
        (("stochastic-heun",), ["stochastic-heun"]),
        (np.array(["euler-maruyama"]), ["euler-maruyama"]),
    ],
)
def test_schemes_may_be_one_string_of_names_as_on_the_command_line(schemes, expected):
    report = sdae.convergence("pendulum", schemes=schemes, paths=4, levels=(2, 3), ref_level=5, progress=False)
    assert sorted({row["scheme"] for row in report.rows}) == sorted(expected)


def test_a_string_of_one_unknown_scheme_is_named_whole():
    with pytest.raises(ValueError, match='^schemes = "half-explicit-practcal": not a built-in scheme'):
        sdae.convergence("pendulum", schemes="half-explicit-practcal")
    with pytest.raises(ValueError, match=r"^schemes = 'euler-maruyama,,stochastic-heun': holds an empty name"):
        sdae.convergence("pendulum", schemes="euler-maruyama,,stochastic-heun")


def test_eps_may_be_one_number_or_a_numpy_array(tmp_path, command_line):
    one = sdae.mlmc("pendulum", quick=True, eps=0.05, standard=False, progress=False)
    array = sdae.mlmc("pendulum", quick=True, eps=np.array([0.05]), standard=False, progress=False)
    assert list(one.settings["spec"]["eps"]) == [0.05]
    assert_same_numbers(command_line, tmp_path, one.to_json(), array.to_json())


# A bool where a whole number goes, a string where a number goes, anything but names where
# names go: a TypeError naming the keyword.
WRONG_KINDS = [
    (lambda: sdae.convergence("pendulum", paths=True), "paths = True: must be a whole number, not bool"),
    (lambda: sdae.convergence("pendulum", seed=True), "seed = True"),
    (lambda: sdae.convergence("pendulum", threads=True), "threads = True"),
    (lambda: sdae.convergence("pendulum", levels=(True, 5)), "levels[0] = True"),
    (lambda: sdae.convergence("pendulum", levels="3..5"), "levels = '3..5': must be a pair of whole numbers"),
    (lambda: sdae.convergence("pendulum", ref_level=False), "ref_level = False"),
    (lambda: sdae.convergence("pendulum", t_end="1"), "t_end = '1': must be a number, not str"),
    (lambda: sdae.convergence("pendulum", p="2"), "p = '2': must be a number"),
    (lambda: sdae.convergence("pendulum", p=True), "p = True: must be a number, not bool"),
    (lambda: sdae.convergence("pendulum", schemes=[1]), "schemes[0] = 1: must be a name"),
    (lambda: sdae.convergence("pendulum", reference_scheme=1), "reference_scheme = 1: must be a name"),
    (lambda: sdae.convergence("pendulum", quick=1), "quick = 1: must be True or False"),
    (lambda: sdae.weak("pendulum", paths=True), "paths = True"),
    (lambda: sdae.weak("pendulum", qmc=True, randomizations=True), "randomizations = True"),
    (lambda: sdae.weak("pendulum", qmc="yes"), "qmc = 'yes': must be True or False"),
    (lambda: sdae.stability("stiff-fiber", seed=True), "seed = True"),
    (lambda: sdae.mlmc("pendulum", eps="0.1"), "eps = '0.1': must be a number or a list of numbers"),
    (lambda: sdae.mlmc("pendulum", eps=["0.1"]), "eps[0] = '0.1': must be a number, not str"),
    (lambda: sdae.mlmc("pendulum", eps=[True]), "eps[0] = True: must be a number, not bool"),
    (lambda: sdae.mlmc("pendulum", coarsest=True), "coarsest = True"),
    (lambda: sdae.mlmc("pendulum", max_level=True), "max_level = True"),
    (lambda: sdae.mlmc("pendulum", test_levels=True), "test_levels = True"),
    (lambda: sdae.mlmc("pendulum", test_samples=True), "test_samples = True"),
    (lambda: sdae.mlmc("pendulum", seed=True), "seed = True"),
    (lambda: sdae.mlmc("pendulum", threads=True), "threads = True"),
    (lambda: sdae.mlmc("pendulum", qmc=True, initial_points=True), "initial_points = True"),
    (lambda: sdae.mlmc("pendulum", observable=["cos_angle"]), "observable = ['cos_angle']: must be a name"),
    (lambda: sdae.expectation("pendulum", eps="0.1"), "eps = '0.1': must be a number, not str"),
    (lambda: sdae.expectation("pendulum", eps=True), "eps = True: must be a number, not bool"),
    (lambda: sdae.expectation("pendulum", eps=0.1, seed=True), "seed = True"),
    (lambda: sdae.expectation("pendulum", eps=0.1, t_end="1"), "t_end = '1'"),
    (lambda: sdae.expectation("pendulum", eps=0.1, scheme=3), "scheme = 3: must be a name"),
]


@pytest.mark.parametrize("call, message", WRONG_KINDS)
def test_a_value_of_the_wrong_kind_is_a_type_error_naming_its_keyword(call, message):
    with pytest.raises(TypeError) as refused:
        call()
    assert str(refused.value).startswith(message), str(refused.value)


def test_a_report_that_cannot_be_written_names_the_folder_and_why(tmp_path):
    report = sdae.convergence("pendulum", paths=4, levels=(2, 3), ref_level=5, progress=False)
    blocked = tmp_path / "a-file"
    blocked.write_text("")
    folder = blocked / "out"
    with pytest.raises(OSError) as refused:
        report.write(folder)
    message = str(refused.value)
    assert message.startswith(f"cannot write the report to the folder {folder}: "), message
    assert os.strerror(errno.ENOTDIR) in message or os.strerror(errno.ENOENT) in message, message


def test_a_scene_value_is_named_by_its_key_in_the_scene_file():
    # The pendulum's reference (2^15 steps) is not above finer levels asked for.
    with pytest.raises(ValueError, match=r"^study.reference = 15: .*\(the scene's value\)$"):
        sdae.convergence("pendulum", levels=(3, 16))
    table = sdae.scene("pendulum").to_dict()
    table["study"]["paths"] = 1
    with pytest.raises(ValueError, match=r"study.paths = 1: must be >= 2"):
        sdae.convergence(table)


def test_progress_is_drawn_on_request_and_cleared(capfd):
    sdae.weak("pendulum", quick=True, progress=False)
    assert capfd.readouterr().err == ""
    sdae.weak("pendulum", quick=True, paths=200, progress=True)
    err = capfd.readouterr().err
    assert "\rpendulum weak: 0/200 paths, 0.0 s" in err, err
    # The line is cleared at the end: the last thing written returns to the line's start.
    assert err.endswith("\r")


# Minutes of work each: a run that ignored the signal would fail the test, not hang it.
LONG_RUNS = [
    lambda: sdae.convergence("pendulum", paths=100_000, levels=(4, 10), ref_level=16, progress=False),
    lambda: sdae.mlmc("pendulum", eps=[1e-4], progress=False),
    lambda: sdae.expectation("noisy-pendulum", eps=1e-4, progress=False),
]


@pytest.mark.parametrize("long_run", LONG_RUNS)
def test_ctrl_c_stops_a_study_within_a_second_and_the_interpreter_goes_on(long_run):
    timer = threading.Timer(0.5, _thread.interrupt_main)
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        long_run()
    elapsed = time.monotonic() - start
    timer.cancel()
    assert elapsed < 0.5 + 1.0
    assert sdae.convergence("pendulum", paths=4, levels=(2, 3), ref_level=5, progress=False).kind == "convergence"


def test_the_example_runs(tmp_path):
    example = pathlib.Path(__file__).resolve().parents[1] / "examples" / "pendulum.py"
    done = subprocess.run(
        [sys.executable, str(example)], cwd=tmp_path, capture_output=True, text=True, check=True
    )
    assert "E[cos_angle(X_T)] of pendulum" in done.stdout
    assert "# Convergence study: pendulum" in done.stdout
