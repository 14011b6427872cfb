"""Type stubs of the native module ``sdae._sdae``."""

import os
import pathlib
from typing import Any, Dict, List, Optional

import numpy as np
import numpy.typing as npt

__version__: str

def built_in_scenes() -> List[str]:
    """The names of the built-in scenes."""

def schemes() -> List[str]:
    """The names of the built-in schemes."""

class Scene:
    """A scene: a system, its parameters, the initial state, T and the study defaults.

    Each way of making one checks the whole scene, as the command line does before a study:
    its values, its system built from its parameters and its initial state on the constraint;
    ValueError naming the key where a check refuses it."""

    @staticmethod
    def built_in(name: str) -> "Scene":
        """The built-in scene ``name``; ValueError if there is none."""
    @staticmethod
    def from_toml(text: str) -> "Scene":
        """The scene written as TOML text; ValueError naming the key where it is refused."""
    @staticmethod
    def from_file(path: "str | os.PathLike[str]") -> "Scene":
        """The scene of a TOML file; OSError if it cannot be read, ValueError if refused."""
    @staticmethod
    def from_dict(table: Dict[str, Any]) -> "Scene":
        """The scene of a dict with the keys of a scene file (numpy scalars and 1-D arrays
        taken as numbers and lists), its system a built-in kind or ``{"expressions": {...}}``
        (docs/custom-systems.md); ValueError naming the dotted key (``system.pendulum.length``,
        ``system.expressions.constraints[0]``) of a value refused, NaN and infinity included,
        and for a system built in code (``custom``); TypeError for a value no scene file holds
        (a set, an object)."""
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def t_end(self) -> float: ...
    def to_toml(self) -> str:
        """The scene as TOML text (reads back to an equal scene)."""
    def to_dict(self) -> Dict[str, Any]:
        """The scene as a dict with the keys of a scene file."""

class Paths:
    """Recorded paths: arrays over (paths, times, coordinates), with the scene, scheme, seed,
    steps and ``every`` of the run; saved to ``.npz`` files, picklable, and written as XYZ and
    VTK trajectories."""

    @property
    def scheme(self) -> str: ...
    @property
    def h(self) -> float: ...
    @property
    def times(self) -> npt.NDArray[np.float64]:
        """Recorded times, shape (T,)."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """r, shape (P, T, n); NaN after a failed path's last completed step."""
    @property
    def velocities(self) -> npt.NDArray[np.float64]:
        """v, shape (P, T, n)."""
    @property
    def multipliers(self) -> npt.NDArray[np.float64]:
        """mu, shape (P, T, m); mu_0 = 0."""
    @property
    def failures(self) -> List[Optional[str]]:
        """Why each path stopped, or None."""
    @property
    def diagnostics(self) -> Dict[str, npt.NDArray[Any]]:
        """Per-path diagnostics, read-only arrays of length P."""
    @property
    def scene(self) -> Scene:
        """The scene the paths were simulated on."""
    @property
    def seed(self) -> int:
        """Path i drew its increments from the stream (seed, i)."""
    @property
    def steps(self) -> int:
        """N: the step was h = T / N."""
    @property
    def every(self) -> int:
        """t_0, every ``every``-th step and t_N were recorded."""
    def save(self, path: "str | os.PathLike[str]") -> None:
        """Writes the paths to ``path`` as a ``.npz`` file (the name as given): every array,
        the failures, the diagnostics, the scene, the scheme, the seed, ``steps`` and
        ``every``; OSError if it cannot be written. ``numpy.load`` reads it without pickled
        objects."""
    @staticmethod
    def load(path: "str | os.PathLike[str]") -> "Paths":
        """The paths of a file written by ``save``, equal to the saved ones; OSError if it
        cannot be read, ValueError naming the file and what is wrong if it holds anything
        else."""
    def to_xyz(self, folder: "str | os.PathLike[str]") -> List[pathlib.Path]:
        """Writes extended XYZ files into ``folder`` (made if missing), one per path,
        ``<scene>.path-<p>.xyz``, a frame per recorded time (VMD, OVITO, ASE); returns them. A
        failed path's NaN states are left out. OSError naming a file that cannot be written;
        ValueError for a scene whose coordinates are not points."""
    def to_vtk(self, folder: "str | os.PathLike[str]") -> List[pathlib.Path]:
        """Writes VTK files into ``folder`` (made if missing): an unstructured grid per
        recorded time, ``<scene>.<j>.vtu``, each path's chain of beads a polyline, and the
        collection ``<scene>.pvd`` that ParaView opens as one time series; returns the
        collection, then the grids by time. ValueError for a scene that is not a chain of beads
        in 3-D (a fiber, a chain molecule); OSError as ``to_xyz``."""
    @staticmethod
    def _from_state(state: Dict[str, Any]) -> "Paths":
        """The paths of the state a pickle holds (``__reduce__``)."""
    def __reduce__(self) -> Any:
        """Pickles as the entries ``save`` writes."""
    def __eq__(self, other: object) -> bool:
        """The same scheme, h, scene, seed, steps, every and failures, and arrays equal element
        by element (NaN equal to NaN)."""

def simulate(
    scene: Scene,
    scheme: str,
    paths: int,
    steps: int,
    seed: int,
    every: int,
    threads: int,
    progress: Optional[float] = None,
) -> Paths:
    """Simulates paths of a scene; see ``sdae.simulate`` (every argument given, checked there:
    here a bool passes as an int). ``threads`` is 1 to 1024; at most one per path and 4 per
    available core are started."""

class Report:
    """A finished study's report as the command line writes it."""

    @property
    def kind(self) -> str:
        """"convergence", "weak", "stability", "mlmc" or "expectation"."""
    def to_json(self) -> str:
        """The report as the command line's JSON file."""
    @property
    def csv(self) -> str:
        """The report's CSV tables, a blank line between two tables."""
    @property
    def markdown(self) -> str:
        """The report in Markdown."""
    def write(self, folder: "str | os.PathLike[str]") -> None:
        """Writes the command line's files of the study into ``folder`` (made if missing);
        OSError naming the folder or file that cannot be written, and why."""

# The studies take the keywords of the package's functions of the same names (``sdae.convergence``
# and so on), which document them; ``progress`` is here the seconds before the progress line is
# drawn, or None for no line. The package's functions check the keywords' kinds (``sdae._args``);
# here a bool passes as an int.

def convergence(scene: Scene, **options: Any) -> Report:
    """The convergence study; see ``sdae.convergence``."""

def weak(scene: Scene, **options: Any) -> Report:
    """The weak-error study; see ``sdae.weak`` (randomizations given: QMC paths)."""

def stability(scene: Scene, **options: Any) -> Report:
    """The stability study; see ``sdae.stability``."""

def mlmc(scene: Scene, **options: Any) -> Report:
    """The MLMC study; see ``sdae.mlmc`` (randomizations or initial_points given: MLQMC too)."""

def expectation(scene: Scene, *, eps: float, **options: Any) -> Report:
    """E[f(X_T)] to accuracy eps; see ``sdae.expectation``."""
