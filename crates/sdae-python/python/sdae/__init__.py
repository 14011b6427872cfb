"""Constrained stochastic mechanical systems from Python.

Scenes (a system, its parameters, the initial state and T) come built in, from TOML files or
from dicts with the keys of a scene file; ``simulate`` steps many paths of a scene with one of
the library's schemes and returns numpy arrays. The studies of the command line run with its
options and return reports (``convergence``, ``weak``, ``stability``, ``mlmc``), and
``expectation`` estimates E[f(X_T)] to a requested accuracy.

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
from typing import Any, Mapping, Optional, Sequence, Tuple, Union

from . import _sdae
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
    ``.toml`` or holds a path separator) is read as a file: OSError if it cannot be read. Raises
    ValueError where the scene's checks refuse it, with the message the command line prints.
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
    reach Python's main thread only). A negative count or seed, or a setting the library refuses
    (including states that would not fit in memory), raises ValueError naming it. A progress
    line is drawn on stderr for runs over a second where stderr is a terminal
    (``progress=True`` always, ``False`` never).
    """
    return _sdae.simulate(
        scene(source), scheme, paths, steps, seed, every, threads, _progress(progress)
    )


def _progress(progress: Optional[bool]) -> Optional[float]:
    """The seconds after which a run draws its progress line on stderr, or None for no line:
    by default after a second where stderr is a terminal; True draws it at once."""
    if progress is None:
        stream = sys.stderr
        return 1.0 if stream is not None and getattr(stream, "isatty", lambda: False)() else None
    return 0.0 if progress else None


def _randomizations(qmc: bool, randomizations: Optional[int], default: int) -> Optional[int]:
    """The randomizations of a QMC run (None: Monte Carlo); given without qmc=True, refused."""
    if not qmc:
        if randomizations is not None:
            raise ValueError(f"randomizations = {randomizations}: needs qmc=True")
        return None
    return default if randomizations is None else randomizations


# The docstrings' common part.
_RUNS = """
    Keywords left at None keep the scene's values, as options not given on the command line
    do; the report equals the command line's JSON for the same options (timings aside). The
    interpreter's lock is released during the run; Ctrl-C raises KeyboardInterrupt. A progress
    line is drawn on stderr for runs over a second where stderr is a terminal (``progress=True``
    always, ``False`` never). A refused setting raises ValueError naming its keyword (or the
    scene file's key when the value came from the scene)."""


def convergence(
    source: SceneLike = "pendulum",
    *,
    schemes: Optional[Sequence[str]] = None,
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
    the same Brownian paths, with 95% intervals, observed orders and run time.
    """
    native = _sdae.convergence(
        scene(source),
        schemes=list(schemes) if schemes is not None else None,
        reference_scheme=reference_scheme,
        levels=tuple(levels) if levels is not None else None,
        ref_level=ref_level,
        t_end=t_end,
        p=p,
        paths=paths,
        seed=seed,
        threads=threads,
        quick=quick,
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
        paths=paths,
        seed=seed,
        threads=threads,
        quick=quick,
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
        paths=paths,
        seed=seed,
        threads=threads,
        quick=quick,
        progress=_progress(progress),
    )
    return Report(native)


def mlmc(
    source: SceneLike = "pendulum",
    *,
    observable: Optional[str] = None,
    scheme: Optional[str] = None,
    eps: Optional[Sequence[float]] = None,
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
    """The MLMC study (``sdae-study mlmc``) of E[f(X_T)] of a built-in ``observable``: the
    convergence test, the rates alpha, beta, gamma, the adaptive runs at each ``eps`` (the
    complexity table), and a direct standard Monte Carlo run (``standard=False`` leaves it
    out). ``qmc=True`` adds multilevel randomized QMC (``randomizations``, default 32,
    ``initial_points``, default 32).
    """
    if not qmc and initial_points is not None:
        raise ValueError(f"initial_points = {initial_points}: needs qmc=True")
    r = _randomizations(qmc, randomizations, 32)
    native = _sdae.mlmc(
        scene(source),
        observable=observable,
        scheme=scheme,
        eps=[float(e) for e in eps] if eps is not None else None,
        antithetic=antithetic,
        coarsest=coarsest,
        max_level=max_level,
        test_levels=test_levels,
        test_samples=test_samples,
        t_end=t_end,
        seed=seed,
        threads=threads,
        quick=quick,
        standard=standard,
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
    progress: Optional[bool] = None,
) -> Expectation:
    """E[f(X_T)] of a built-in ``observable`` (default: the scene's) to root mean square
    accuracy ``eps``, with its 95% interval and bias estimate.

    A convergence test (``test_levels``, ``test_samples``: the scene's MLMC settings) predicts
    the work, in steps, of multilevel Monte Carlo and of standard Monte Carlo on the finest
    level the bias needs; the cheaper one runs (``method`` says which). When the test's levels
    do not resolve the bias, the adaptive MLMC algorithm runs and adds levels itself.
    """
    native = _sdae.expectation(
        scene(source),
        eps=float(eps),
        observable=observable,
        scheme=scheme,
        antithetic=antithetic,
        coarsest=coarsest,
        max_level=max_level,
        test_levels=test_levels,
        test_samples=test_samples,
        t_end=t_end,
        seed=seed,
        threads=threads,
        progress=_progress(progress),
    )
    return Expectation(native)


for _study in (convergence, weak, stability, mlmc, expectation):
    _study.__doc__ = (_study.__doc__ or "").rstrip() + "\n" + _RUNS
