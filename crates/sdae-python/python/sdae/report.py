"""Study reports as Python objects: plain numbers, lists, dicts and numpy arrays."""

from __future__ import annotations

import csv
import io
import json
import os
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from ._sdae import Report as _NativeReport

__all__ = ["Expectation", "Report"]

# How the reports write a number that JSON cannot hold.
_NON_FINITE = {"NaN": float("nan"), "inf": float("inf"), "-inf": float("-inf")}


def _number(value: Any) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)) or (
        isinstance(value, str) and value in _NON_FINITE
    )


def _plain(value: Any) -> Any:
    """A JSON value with lists of numbers as float64 arrays and "NaN"/"inf" as floats."""
    if isinstance(value, dict):
        return {key: _plain(item) for key, item in value.items()}
    if isinstance(value, list):
        if value and all(_number(item) for item in value):
            return np.array([_NON_FINITE.get(item, item) for item in value], dtype=np.float64)
        return [_plain(item) for item in value]
    if isinstance(value, str) and value in _NON_FINITE:
        return _NON_FINITE[value]
    return value


def _cell(text: str) -> Union[int, float, bool, str, None]:
    """A CSV cell as a number, a bool, None (empty) or the text."""
    if text == "":
        return None
    if text in ("true", "false"):
        return text == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _tables(text: str) -> List[List[Dict[str, Any]]]:
    """The CSV tables of `text` (a blank line between two), each a list of rows."""
    tables = []
    for block in text.strip().split("\n\n"):
        if block.strip():
            rows = csv.DictReader(io.StringIO(block))
            tables.append([{key: _cell(value) for key, value in row.items()} for row in rows])
    return tables


class Report:
    """A study's report.

    - ``to_dict()``: the content of the command line's JSON file for the same study (``to_json()``
      its text);
    - the JSON's top-level fields as attributes (``report.schemes``, ``report.seed``), lists of
      numbers as numpy float64 arrays, numbers JSON cannot hold ("NaN", "inf") as floats;
    - ``rows``: the report's first CSV table as a list of dicts, so that
      ``pandas.DataFrame(report.rows)`` is the command line's CSV file; ``tables``: every table;
    - ``markdown``: the summary the command line writes (notebooks show it);
    - ``write(folder)``: the command line's files (JSON, CSV, Markdown, SVG plots).
    """

    def __init__(self, native: _NativeReport) -> None:
        self._native = native
        self._content: Optional[Dict[str, Any]] = None

    @property
    def kind(self) -> str:
        """The study: "convergence", "weak", "stability", "mlmc" or "expectation"."""
        return self._native.kind

    def to_json(self) -> str:
        """The report as the text of the command line's JSON file."""
        return self._native.to_json()

    def to_dict(self) -> Dict[str, Any]:
        """The report as the command line's JSON file holds it (a new dict on each call)."""
        return json.loads(self._native.to_json())

    def _fields(self) -> Dict[str, Any]:
        if self._content is None:
            self._content = _plain(self.to_dict())
        return self._content

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        fields = self._fields()
        if name in fields:
            return fields[name]
        raise AttributeError(f"a {self.kind} report has no field {name!r} (fields: {', '.join(fields)})")

    def __dir__(self) -> List[str]:
        return sorted(set(super().__dir__()) | set(self._fields()))

    @property
    def tables(self) -> List[List[Dict[str, Any]]]:
        """The report's CSV tables, each a list of rows (dicts of numbers and names)."""
        return _tables(self._native.csv)

    @property
    def rows(self) -> List[Dict[str, Any]]:
        """The first CSV table: one row per scheme and step size (convergence, stability), per
        observable, scheme and step size (weak), per level of the convergence test (MLMC)."""
        tables = self.tables
        return tables[0] if tables else []

    @property
    def csv(self) -> str:
        """The report's CSV text."""
        return self._native.csv

    @property
    def markdown(self) -> str:
        """The report in Markdown."""
        return self._native.markdown

    def write(self, folder: Union[str, "os.PathLike[str]"]) -> None:
        """Writes the command line's files of the study into ``folder`` (made if missing);
        OSError naming the folder, or the file, that cannot be written, and why."""
        self._native.write(os.fspath(folder))

    def _repr_markdown_(self) -> str:
        return self.markdown

    def __repr__(self) -> str:
        scene = self._fields().get("scene", "")
        return f"Report({self.kind!r}, scene={scene!r})" if scene else f"Report({self.kind!r})"


class Expectation(Report):
    """E[f(X_T)] to a requested accuracy: ``value``, its ``interval`` (the 95% sampling
    interval widened by the ``bias`` estimate at the finest level used), the ``sampling_interval``
    alone (an interval for the finest level's law), and how it was found (``method`` "mlmc",
    "mlqmc", "standard" or "rqmc", the one the pilot predicted cheapest unless forced;
    ``predicted``, the predicted cost of each estimator in steps and seconds; ``level``,
    ``samples``)."""

    @property
    def value(self) -> float:
        """The estimate of E[f(X_T)]."""
        return float(self._fields()["estimate"]["estimate"])

    @property
    def interval(self) -> Tuple[float, float]:
        """The interval for E[f(X_T)]: the 95% sampling interval widened by ``bias`` on each
        side."""
        with_bias = self._fields()["with_bias"]
        return float(with_bias["ci_low"]), float(with_bias["ci_high"])

    @property
    def sampling_interval(self) -> Tuple[float, float]:
        """The 95% interval from the sampling variance alone: an interval for E[P_L], the
        finest level's law, without its bias."""
        estimate = self._fields()["estimate"]
        return float(estimate["ci_low"]), float(estimate["ci_high"])

    def __repr__(self) -> str:
        return self.markdown.strip()
