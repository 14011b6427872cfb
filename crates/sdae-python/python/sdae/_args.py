"""The package's keyword values checked before a run: each as the library takes it, or a
TypeError (a value of the wrong kind) or ValueError (a value out of place) naming the keyword.

A bool is refused where a whole number goes (``paths=True`` is a mistake, not one path), a
string where a number goes (``eps='0.1'``), and a list of names may be given as one string,
comma-separated as on the command line (``schemes="euler-maruyama,stochastic-heun"``).
"""

from __future__ import annotations

import numbers
import operator
from typing import Any, List, Optional, Tuple

import numpy as np


def _shown(value: Any) -> str:
    """`value` as the message shows it: its repr, cut after 60 characters."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _refused(name: str, value: Any, wanted: str) -> TypeError:
    """The TypeError of `value` given for `name`, which takes `wanted`."""
    return TypeError(f"{name} = {_shown(value)}: must be {wanted}, not {type(value).__name__}")


def _one_dimensional(name: str, value: Any) -> None:
    """Refuses a numpy array of other than one dimension."""
    if isinstance(value, np.ndarray) and value.ndim != 1:
        raise ValueError(f"{name}: must be a 1-D array, not of shape {value.shape}")


def whole(name: str, value: Any) -> int:
    """`value` as a Python int: an int or a numpy integer, not a bool, a float or a string."""
    if isinstance(value, (bool, np.bool_)):
        raise _refused(name, value, "a whole number")
    try:
        return operator.index(value)
    except TypeError:
        raise _refused(name, value, "a whole number") from None


def optional_whole(name: str, value: Any) -> Optional[int]:
    """None, or `value` as ``whole`` takes it."""
    return None if value is None else whole(name, value)


def real(name: str, value: Any) -> float:
    """`value` as a float: an int, a float or a numpy number, not a bool or a string."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise _refused(name, value, "a number")
    return float(value)


def optional_real(name: str, value: Any) -> Optional[float]:
    """None, or `value` as ``real`` takes it."""
    return None if value is None else real(name, value)


def reals(name: str, value: Any) -> List[float]:
    """A list of numbers: a number (one), a list, a tuple or a 1-D numpy array of numbers; a
    string is refused, as is an entry ``real`` refuses (named ``name[i]``)."""
    if isinstance(value, (str, bytes)):
        raise _refused(name, value, "a number or a list of numbers")
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        return [float(value)]
    _one_dimensional(name, value)
    if not isinstance(value, (list, tuple, np.ndarray)):
        raise _refused(name, value, "a number or a list of numbers")
    return [real(f"{name}[{i}]", x) for i, x in enumerate(value)]


def text(name: str, value: Any) -> str:
    """A string (a name)."""
    if not isinstance(value, str):
        raise _refused(name, value, "a name (a string)")
    return value


def optional_text(name: str, value: Any) -> Optional[str]:
    """None, or `value` as ``text`` takes it."""
    return None if value is None else text(name, value)


def names(name: str, value: Any) -> List[str]:
    """A list of names: one string holding one name or several comma-separated (as on the
    command line), or a list, a tuple or a 1-D numpy array of strings; an empty name is
    refused."""
    _one_dimensional(name, value)
    if isinstance(value, str):
        items = [item.strip() for item in value.split(",")]
    elif isinstance(value, (list, tuple, np.ndarray)):
        items = [text(f"{name}[{i}]", item) for i, item in enumerate(value)]
    else:
        raise _refused(name, value, "a name or a list of names")
    if any(not item for item in items):
        raise ValueError(f"{name} = {_shown(value)}: holds an empty name")
    return items


def levels(name: str, value: Any) -> Tuple[int, int]:
    """A pair of whole numbers (a list, a tuple or a numpy array of two); not a string."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
        raise _refused(name, value, "a pair of whole numbers (a, b)")
    _one_dimensional(name, value)
    if len(value) != 2:
        raise ValueError(f"{name} = {_shown(value)}: must be a pair (a, b), not {len(value)} numbers")
    return whole(f"{name}[0]", value[0]), whole(f"{name}[1]", value[1])


def flag(name: str, value: Any) -> bool:
    """True or False (a numpy bool too); not a number or a string."""
    if not isinstance(value, (bool, np.bool_)):
        raise _refused(name, value, "True or False")
    return bool(value)


def optional_flag(name: str, value: Any) -> Optional[bool]:
    """None, or `value` as ``flag`` takes it."""
    return None if value is None else flag(name, value)
