"""Constrained stochastic mechanical systems from Python.

Scenes (a system, its parameters, the initial state and T) come built in, from TOML files or
from dicts with the keys of a scene file; ``simulate`` steps many paths of a scene with one of
the library's schemes and returns numpy arrays. The studies of the command line run with its
options and return reports (``convergence``, ``weak``, ``stability``, ``mlmc``), and
``expectation`` estimates E[f(X_T)] to a requested accuracy. Paths are saved to ``.npz`` files
(``Paths.save``, ``load_paths``) and pickled with their scene, scheme and seed, and written as
extended XYZ and VTK trajectories (``Paths.to_xyz``, ``Paths.to_vtk``).

>>> import sdae
>>> paths = sdae.simulate("pendulum", "half-explicit-practical", paths=8, steps=256, seed=1, every=64)
>>> paths.positions.shape
(8, 5, 2)
>>> report = sdae.convergence("pendulum", paths=8, levels=(3, 5), ref_level=8, progress=False)
>>> [row["n_steps"] for row in report.rows if row["scheme"] == "half-explicit-practical"]
[8, 16, 32]
"""

from __future__ import annotations

import os
import sys
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple, Union

from . import _args, _sdae
from ._sdae import Paths, Scene, __version__, built_in_scenes, schemes
from .report import Expectation, Report

__all__ = [
    "Expectation",
    "Paths",
    "Report",
    "Scene",
    "__version__",
    "built_in_scenes",
    "convergence",
    "expectation",
    "load_paths",
    "mlmc",
    "scene",
    "schemes",
    "simulate",
    "stability",
    "weak",
]

SceneLike = Union[Scene, str, "os.PathLike[str]", Mapping[str, Any]]


def scene(source: SceneLike) -> Scene:
    """A scene from a built-in name, a path to a TOML scene file, a dict with the keys of a
    scene file, or a Scene (returned as it is).

    A path (an ``os.PathLike``, or a str that is not a built-in name and names a file, ends in
    ``.toml`` or holds a path separator) is read as a file: OSError if it cannot be read. A dict
    takes numbers where a scene file does (numpy scalars too) and lists or 1-D numpy arrays
    where it has lists; NaN and infinity are refused, naming the key (``system.pendulum.length``).

    Its ``system`` is one of the built-in kinds (``{"pendulum": {...}}``, ``chain-molecule``,
    ``triatomic``, ``fiber``) or a system written as expressions, ``{"expressions": {...}}``:
    coordinates, masses, parameters, constraints, a potential, forces, friction and kT or
    noise, observables and the initial state, as text (docs/custom-systems.md). A ``weak``
    table's observables, like the ``observable`` of ``mlmc`` and ``expectation``, may then be
    expressions of the coordinates and velocities too. A system built in code (``custom``)
    runs from Rust only and is refused.

    The whole scene is checked here, as the command line checks it before a study: its values,
    its system built from its parameters (a negative length, a pendulum of 4 dimensions) and
    its initial state on the constraint; a system written as expressions is compiled here. Raises
    ValueError where a check refuses it, naming the key, with the message the command line
    prints (an expression that does not parse with its text and a caret under the position).
    """
    if isinstance(source, Scene):
        return source
    if isinstance(source, Mapping):
        return Scene.from_dict(dict(source))
    if isinstance(source, os.PathLike):
        return Scene.from_file(os.fspath(source))
    if isinstance(source, str):
        if source in built_in_scenes():
            return Scene.built_in(source)
        if os.path.exists(source) or source.endswith(".toml") or os.sep in source:
            return Scene.from_file(source)
        return Scene.built_in(source)
    raise TypeError(f"a scene is a name, a path, a dict or a Scene, not {type(source).__name__}")


def load_paths(path: "str | os.PathLike[str]") -> Paths:
    """The paths of a ``.npz`` file written by ``Paths.save``, equal to the saved ones: every
    array, the failures, the diagnostics, the scene, the scheme, the seed, the steps and
    ``every``. OSError if the file cannot be read; ValueError naming the file and what is wrong
    (a missing entry, an array of the wrong shape or dtype) if it holds anything else. No
    pickled objects are read."""
    return Paths.load(path)


def simulate(
    source: SceneLike,
    scheme: str = "half-explicit-practical",
    *,
    paths: int,
    steps: int,
    seed: int = 0,
    every: int = 1,
    threads: int = 1,
    progress: Optional[bool] = None,
) -> Paths:
    """Simulates ``paths`` paths of a scene with ``scheme`` (see ``schemes()``) over ``steps``
    steps of h = T / steps from the scene's initial state.

    Path i draws its increments from the stream (seed, i): the numbers are the library's for the
    same settings, whatever ``threads``. The states at t_0, every ``every``-th step and t_N come
    back as arrays of shape (paths, times, n) (``positions``, ``velocities``) and (paths, times,
    m) (``multipliers``), float64 and C-contiguous. A path that failed holds NaN after its last
    completed step; ``failures`` says why. The arrays are read-only (copy one to change it). The
    interpreter's lock is released during the run, and Ctrl-C raises KeyboardInterrupt (signals
    reach Python's main thread only). ``threads`` is 1 to 1024, as on the command line; more
    than one per path or 4 per available core are not started. A negative count or seed, or a
    setting the library refuses (including states that would not fit in memory), raises
    ValueError naming it; a bool or a float where a whole number goes, or anything but a string
    for ``scheme``, raises TypeError naming it. A progress line is drawn on stderr for runs over
    a second where stderr is a terminal (``progress=True`` always, ``False`` never).

    Memory: ``every=1``, the default, keeps every step. The arrays take
    paths x times x (2n + m) x 8 bytes, with times = ceil(steps / every) + 1, and the run holds
    them twice until it returns: 10 000 paths x 1 024 steps of the pendulum (n = 2, m = 1) are
    410 MB of arrays, and the process peaks at about 855 MB. ``every=steps`` keeps t_0 and the
    end state only (times = 2); ``every=64`` keeps 17 times of 1 024 steps.

    The paths keep their scene, scheme, seed, ``steps`` and ``every``: ``Paths.save`` writes
    them to a ``.npz`` file that ``load_paths`` reads back, they pickle, and ``Paths.to_xyz``
    and ``Paths.to_vtk`` write trajectory files for VMD, OVITO and ParaView.
    """
    return _sdae.simulate(
        scene(source),
        _args.text("scheme", scheme),
        _args.whole("paths", paths),
        _args.whole("steps", steps),
        _args.whole("seed", seed),
        _args.whole("every", every),
        _args.whole("threads", threads),
        _progress(progress),
    )


def _progress(progress: Optional[bool]) -> Optional[float]:
    """The seconds after which a run draws its progress line on stderr, or None for no line:
    by default after a second where stderr is a terminal; True draws it at once."""
    progress = _args.optional_flag("progress", progress)
    if progress is None:
        stream = sys.stderr
        return 1.0 if stream is not None and getattr(stream, "isatty", lambda: False)() else None
    return 0.0 if progress else None


def _randomizations(qmc: bool, randomizations: Optional[int], default: int) -> Optional[int]:
    """The randomizations of a QMC run (None: Monte Carlo); given without qmc=True, refused."""
    randomizations = _args.optional_whole("randomizations", randomizations)
    if not _args.flag("qmc", qmc):
        if randomizations is not None:
            raise ValueError(f"randomizations = {randomizations}: needs qmc=True")
        return None
    return default if randomizations is None else randomizations


def _ensemble(paths: Any, seed: Any, threads: Any, quick: Any) -> Dict[str, Any]:
    """The keywords of every study over paths, checked (``_args``)."""
    return {
        "paths": _args.optional_whole("paths", paths),
        "seed": _args.optional_whole("seed", seed),
        "threads": _args.optional_whole("threads", threads),
        "quick": _args.flag("quick", quick),
    }


def _mlmc_keywords(
    observable: Any,
    scheme: Any,
    antithetic: Any,
    levels: Tuple[Any, Any, Any, Any],
    run: Tuple[Any, Any, Any],
) -> Dict[str, Any]:
    """The keywords of the MLMC study and the expectation helper, checked (``_args``):
    ``levels`` are coarsest, max_level, test_levels and test_samples, ``run`` t_end, seed and
    threads."""
    coarsest, max_level, test_levels, test_samples = levels
    t_end, seed, threads = run
    return {
        "observable": _args.optional_text("observable", observable),
        "scheme": _args.optional_text("scheme", scheme),
        "antithetic": _args.flag("antithetic", antithetic),
        "coarsest": _args.optional_whole("coarsest", coarsest),
        "max_level": _args.optional_whole("max_level", max_level),
        "test_levels": _args.optional_whole("test_levels", test_levels),
        "test_samples": _args.optional_whole("test_samples", test_samples),
        "t_end": _args.optional_real("t_end", t_end),
        "seed": _args.whole("seed", seed),
        "threads": _args.optional_whole("threads", threads),
    }


# The docstrings' common part.
_RUNS = """
    Keywords left at None keep the scene's values, as options not given on the command line
    do; the report equals the command line's JSON for the same options (timings aside). The
    interpreter's lock is released during the run; Ctrl-C raises KeyboardInterrupt. A progress
    line is drawn on stderr for runs over a second where stderr is a terminal (``progress=True``
    always, ``False`` never). A refused setting raises ValueError naming its keyword (or the
    scene file's key when the value came from the scene); a value of the wrong kind (a bool or a
    float where a whole number goes, a string where a number goes) raises TypeError naming its
    keyword. ``threads`` is 1 to 1024, as on the command line (the studies over paths, as there,
    start at most one per path and 4 per available core)."""


def convergence(
    source: SceneLike = "pendulum",
    *,
    schemes: Optional[Union[str, Sequence[str]]] = None,
    reference_scheme: Optional[str] = None,
    levels: Optional[Tuple[int, int]] = None,
    ref_level: Optional[int] = None,
    t_end: Optional[float] = None,
    p: Optional[float] = None,
    paths: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    quick: bool = False,
    progress: Optional[bool] = None,
) -> Report:
    """The convergence study (``sdae-study convergence``): strong errors of each scheme at
    N = 2^a..2^b steps (``levels=(a, b)``) against a reference on 2^r steps (``ref_level``) on
    the same Brownian paths, with 95% intervals, observed orders and run time. ``schemes`` is a
    list of names or one string, comma-separated as on the command line
    (``"euler-maruyama,stochastic-heun"``).
    """
    native = _sdae.convergence(
        scene(source),
        schemes=_args.names("schemes", schemes) if schemes is not None else None,
        reference_scheme=_args.optional_text("reference_scheme", reference_scheme),
        levels=_args.levels("levels", levels) if levels is not None else None,
        ref_level=_args.optional_whole("ref_level", ref_level),
        t_end=_args.optional_real("t_end", t_end),
        p=_args.optional_real("p", p),
        **_ensemble(paths, seed, threads, quick),
        progress=_progress(progress),
    )
    return Report(native)


def weak(
    source: SceneLike = "pendulum",
    *,
    qmc: bool = False,
    randomizations: Optional[int] = None,
    paths: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    quick: bool = False,
    progress: Optional[bool] = None,
) -> Report:
    """The weak-error study (``sdae-study weak``) of a scene with a [weak] table: E[f(X_N)] -
    E[f(X_T)] of its observables against exact values or the reference, weak orders and
    Richardson-Romberg extrapolation. ``qmc=True`` runs randomized quasi-Monte Carlo paths
    (``randomizations``, default 16).
    """
    native = _sdae.weak(
        scene(source),
        randomizations=_randomizations(qmc, randomizations, 16),
        **_ensemble(paths, seed, threads, quick),
        progress=_progress(progress),
    )
    return Report(native)


def stability(
    source: SceneLike,
    *,
    paths: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    quick: bool = False,
    progress: Optional[bool] = None,
) -> Report:
    """The stability study (``sdae-study stability``) of a scene with a [stability] table:
    failures by kind, constraint residuals and truncation over a range of step sizes.
    """
    native = _sdae.stability(
        scene(source),
        **_ensemble(paths, seed, threads, quick),
        progress=_progress(progress),
    )
    return Report(native)


def mlmc(
    source: SceneLike = "pendulum",
    *,
    observable: Optional[str] = None,
    scheme: Optional[str] = None,
    eps: Optional[Union[float, Sequence[float]]] = None,
    antithetic: bool = False,
    coarsest: Optional[int] = None,
    max_level: Optional[int] = None,
    test_levels: Optional[int] = None,
    test_samples: Optional[int] = None,
    t_end: Optional[float] = None,
    seed: int = 2026,
    threads: Optional[int] = None,
    quick: bool = False,
    standard: bool = True,
    qmc: bool = False,
    randomizations: Optional[int] = None,
    initial_points: Optional[int] = None,
    progress: Optional[bool] = None,
) -> Report:
    """The MLMC study (``sdae-study mlmc``) of E[f(X_T)] of an ``observable`` of the scene's
    system (for a system written as expressions, any expression of its coordinates and
    velocities too, ``"x1^2 + v_y1"``): the convergence test, the rates alpha, beta, gamma, the adaptive runs at each ``eps`` (the
    complexity table; a list, a 1-D numpy array or one number), and a direct standard Monte
    Carlo run (``standard=False`` leaves it out). ``qmc=True`` adds multilevel randomized QMC
    (``randomizations``, default 32, ``initial_points``, default 32).
    """
    initial_points = _args.optional_whole("initial_points", initial_points)
    if not _args.flag("qmc", qmc) and initial_points is not None:
        raise ValueError(f"initial_points = {initial_points}: needs qmc=True")
    r = _randomizations(qmc, randomizations, 32)
    native = _sdae.mlmc(
        scene(source),
        eps=_args.reals("eps", eps) if eps is not None else None,
        **_mlmc_keywords(
            observable,
            scheme,
            antithetic,
            (coarsest, max_level, test_levels, test_samples),
            (t_end, seed, threads),
        ),
        quick=_args.flag("quick", quick),
        standard=_args.flag("standard", standard),
        randomizations=r,
        initial_points=(initial_points if initial_points is not None else 32) if qmc else None,
        progress=_progress(progress),
    )
    return Report(native)


def expectation(
    source: SceneLike = "pendulum",
    observable: Optional[str] = None,
    *,
    eps: float,
    scheme: Optional[str] = None,
    antithetic: bool = False,
    coarsest: Optional[int] = None,
    max_level: Optional[int] = None,
    test_levels: Optional[int] = None,
    test_samples: Optional[int] = None,
    t_end: Optional[float] = None,
    seed: int = 2026,
    threads: Optional[int] = None,
    method: Optional[str] = None,
    pick_by: str = "work",
    randomizations: Optional[int] = None,
    initial_points: Optional[int] = None,
    progress: Optional[bool] = None,
) -> Expectation:
    """E[f(X_T)] of an ``observable`` of the scene's system (default: the scene's; for a system
    written as expressions, any expression of its coordinates and velocities too) to root mean
    square accuracy ``eps``, with its interval (95% widened by the bias estimate) and bias estimate.

    A short pilot (the convergence test, ``test_levels`` and ``test_samples``: the scene's MLMC
    settings; then ``randomizations`` R of up to ``initial_points`` n_0 quasi-random points per
    level) predicts the cost, in steps and in seconds, of standard Monte Carlo, randomized QMC,
    multilevel Monte Carlo and multilevel QMC; the cheapest by ``pick_by`` ("work" or
    "seconds") runs, or ``method`` ("mlmc", "mlqmc", "standard", "rqmc") whatever the
    prediction. The report's ``method`` says which ran and ``predicted`` what each would cost.
    As ``sdae-study expect`` does (docs/expectations.md).
    """
    native = _sdae.expectation(
        scene(source),
        eps=_args.real("eps", eps),
        **_mlmc_keywords(
            observable,
            scheme,
            antithetic,
            (coarsest, max_level, test_levels, test_samples),
            (t_end, seed, threads),
        ),
        method=_args.optional_text("method", method),
        pick_by=_args.optional_text("pick_by", pick_by),
        randomizations=_args.optional_whole("randomizations", randomizations),
        initial_points=_args.optional_whole("initial_points", initial_points),
        progress=_progress(progress),
    )
    return Expectation(native)


for _study in (convergence, weak, stability, mlmc, expectation):
    _study.__doc__ = (_study.__doc__ or "").rstrip() + "\n" + _RUNS
