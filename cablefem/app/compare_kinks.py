"""``cablefem compare``'s kinks and case check: the moment at each interior kink (a
damper's clamp on a stay, a saddle, a pinned support a cable passes over: ``kinks.csv``)
compared as the clamped anchors are (static moment from ``summary.json``, steady-state peak,
RMS and mean of ``|M|`` over the same window, history error), and the case files compared
without the keys that the model choice sets."""

from __future__ import annotations

import copy
import csv
import math
from pathlib import Path

import numpy as np

__all__ = ["MODEL_KEYS", "read_kinks", "same_case", "compare_kinks"]

#: ``solver`` keys of the echoed case that the model choice sets, not the case: the string
#: resolves ``span_bending = "auto"`` to true or false, the rod leaves it as given (and
#: ignores it); ``model`` is the route asked for ("auto" runs the string or the rod)
MODEL_KEYS = ("span_bending", "model")


def same_case(case_a, case_b) -> bool:
    """Whether two runs' echoed case files are the same case, :data:`MODEL_KEYS` of their
    ``solver`` table left out."""
    def strip(case):
        if not isinstance(case, dict):
            return case
        case = copy.deepcopy(case)
        solver = case.get("solver")
        if isinstance(solver, dict):
            for key in MODEL_KEYS:
                solver.pop(key, None)
        return case

    return strip(case_a) == strip(case_b)


def read_kinks(folder: Path) -> dict[str, dict[str, np.ndarray]]:
    """A run's ``kinks.csv``: kink -> ``time, moment, valid`` arrays (empty cells NaN);
    no kink without the file. ValueError names the file and line of malformed input."""
    path = Path(folder) / "kinks.csv"
    if not path.is_file():
        return {}
    rows: dict[str, list[tuple[float, float, float]]] = {}
    try:
        with path.open(newline="") as fh:
            reader = csv.DictReader(fh)
            missing = [c for c in ("time", "kink", "moment") if c not in (reader.fieldnames
                                                                          or [])]
            if missing:
                raise ValueError(f"{path}:1: header lacks column(s) {', '.join(missing)}")
            for row in reader:
                try:
                    vals = tuple(float(row[c]) if row.get(c) else math.nan
                                 for c in ("time", "moment", "valid"))
                except ValueError:
                    raise ValueError(f"{path}:{reader.line_num}: not a number") from None
                if not math.isfinite(vals[0]):
                    raise ValueError(f"{path}:{reader.line_num}: column 'time': empty")
                rows.setdefault(row["kink"], []).append(vals)
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    out = {}
    for name, r in rows.items():
        a = np.array(r, float)
        if np.any(np.diff(a[:, 0]) <= 0):
            raise ValueError(f"{path}: the times of kink '{name}' are not increasing")
        out[name] = {"time": a[:, 0], "moment": np.abs(a[:, 1]), "valid": a[:, 2]}
    return out


def compare_kinks(ra: dict, rb: dict, t_lo: float, t_hi: float, steady: bool,
                  window_stats, history_error, pair) -> dict:
    """Per kink of both runs (``run["kinks"]`` from :func:`read_kinks`, ``summary.json``'s
    ``kinks`` for the static moment): the entries of compare.json's ``kinks``, the same
    statistics as the clamped anchors' (the functions of :mod:`cablefem.app.compare`)."""
    out = {}
    for name in sorted(set(ra["kinks"]) & set(rb["kinks"])):
        sa = (ra["summary"].get("kinks") or {}).get(name) or {}
        sb = (rb["summary"].get("kinks") or {}).get(name) or {}
        da, db = ra["kinks"][name], rb["kinks"][name]
        if not (np.any(np.isfinite(da["moment"])) and np.any(np.isfinite(db["moment"]))):
            continue
        entry = {"static_moment": pair(sa.get("static_moment"), sb.get("static_moment")),
                 "history_error": {"value": math.nan, "samples": 0, "interpolated": False},
                 "window": None}
        if steady:
            st = [window_stats(d["time"], d["moment"], t_lo, t_hi) for d in (da, db)]
            entry["window"] = st[0]["window"]
            for key in ("peak", "rms", "mean"):
                entry[f"steady_{key}"] = pair(st[0].get(key), st[1].get(key))
            entry["history_error"] = history_error(da["time"], da["moment"], db["time"],
                                                   db["moment"], tuple(entry["window"]))
        else:
            for key in ("peak", "rms", "mean"):
                entry[f"steady_{key}"] = pair(None, None)
        out[name] = entry
    return out
