"""Constrained stochastic mechanical systems from Python.

Scenes (a system, its parameters, the initial state and T) come built in, from TOML files or
from dicts with the keys of a scene file; ``simulate`` steps many paths of a scene with one of
the library's schemes and returns numpy arrays.

>>> import sdae
>>> paths = sdae.simulate("pendulum", "half-explicit-practical", paths=8, steps=256, seed=1, every=64)
>>> paths.positions.shape
(8, 5, 2)
"""

from __future__ import annotations

import os
from typing import Any, Mapping, Union

from ._sdae import Paths, Scene, __version__, built_in_scenes, schemes
from ._sdae import simulate as _simulate

__all__ = ["Paths", "Scene", "__version__", "built_in_scenes", "scene", "schemes", "simulate"]

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
    (including states that would not fit in memory), raises ValueError naming it.
    """
    return _simulate(scene(source), scheme, paths, steps, seed, every, threads)
