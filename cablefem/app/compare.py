"""``cablefem compare DIR_A DIR_B``: two finished runs of a case side by side.

Typically the string + asymptotics (``cablefem run CASE --output A``) against the reference
rod (``cablefem run CASE --model beam --output B``). For every anchor clamped in both runs:
static moment and tension (from ``summary.json``), steady-state peak and RMS of the moment
magnitude ``|M|`` (from ``anchors.csv``, over the last third of the time range the two runs
have in common, so that both use the same window), and the relative differences
``(b - a) / a``; the history error ``RMS(|M|_b - |M|_a) / RMS(|M|_a)``, the pointwise
difference of the two histories over the same window (:func:`history_error`); the same for
every interior kink of both runs (``kinks.csv``, :mod:`cablefem.app.compare_kinks`: a
damper's kink is what a stay-cable user compares; no figure); also the first
natural frequency and the wall times (ratio ``b / a``). Warns (log and ``warnings`` in
``compare.json``) when a run's first output row is not its static state
(:func:`start_warnings`): such a run did not start clean. Writes ``compare.json``,
``compare.md`` and ``compare_<anchor>.png`` (default: into ``DIR_B``). No dolfinx objects:
rank 0 reads, computes and writes; every rank gets the
result (and the same ValueError on bad input).
"""

from __future__ import annotations

import functools
import json
import logging
import math
import re
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem import __version__
from cablefem.app.compare_kinks import compare_kinks, read_kinks, same_case
from cablefem.app.plots import MAX_PANELS
from cablefem.app.statistics import steady_state_stats
from cablefem.io.anchorcsv import read_moments
from cablefem.io.series import jsonable, write_json

__all__ = ["compare_runs", "format_table", "history_error", "start_warnings", "FRACTION",
           "START_TOLERANCE", "statistics_start"]

log = logging.getLogger(__name__)

#: the steady state: the last third of the common time range (as run.steady_state_stats)
FRACTION = 1 / 3
#: a run's first output row may differ from its static state by this fraction of the
#: quantity's scale (the static value, or the run's peak if larger) before compare warns.
#: A clean start (the quasi-static initial velocity, docs/rod.md) differs by the damping
#: force of the quasi-static motion, beta dR/dt <= 2 zeta(omega) times the quasi-static
#: amplitude: 0.09 % of the tension and 0.04 % of the moment on case A (zeta = 0.5 %); an
#: impulsive start (the cable at rest, its anchor moving) by beta EA v0/h: 3.6 % of the
#: tension on the string of case A, 230 % on the rod.
START_TOLERANCE = 0.01


def compare_runs(dir_a: str | Path, dir_b: str | Path, outdir: str | Path | None = None,
                 comm: MPI.Comm = MPI.COMM_WORLD) -> dict:
    """Compare the run folders ``dir_a`` and ``dir_b``; write ``compare.json``,
    ``compare.md`` and the figures to ``outdir`` (default ``dir_b``) and return the
    comparison (on every rank). Raises ValueError naming the folder or file on bad input
    (missing or malformed file, different anchors, no anchor clamped in both runs with
    moments)."""
    dir_a, dir_b = Path(dir_a), Path(dir_b)
    outdir = Path(outdir) if outdir is not None else dir_b
    result, error = None, None
    if comm.rank == 0:
        try:
            result = _compare(dir_a, dir_b, outdir)
        except ValueError as err:
            error = str(err)
        except OSError as err:  # unreadable input, unwritable output
            error = f"{err.filename or outdir}: {err.strerror or err}"
    error = comm.bcast(error, root=0)
    if error is not None:
        raise ValueError(error)
    return comm.bcast(result, root=0)


# reading -----------------------------------------------------------------------------------
def _read_run(folder: Path) -> dict:
    """summary.json and anchors.csv of a run folder, checked."""
    if not folder.is_dir():
        raise ValueError(f"{folder}: no such run folder")
    path = folder / "summary.json"
    if not path.is_file():
        raise ValueError(f"{path}: no such file (not a cablefem run folder?)")
    try:
        summary = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise ValueError(f"{path}: not valid JSON (line {err.lineno}, column {err.colno}: "
                         f"{err.msg})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    if not isinstance(summary, dict):
        raise ValueError(f"{path}: not a JSON object")
    anchors = summary.get("anchors")
    if not isinstance(anchors, dict) or not anchors or not all(
            isinstance(v, dict) for v in anchors.values()):
        raise ValueError(f"{path}: no 'anchors' table (a run that did not finish?)")
    model = summary.get("model", "string")  # runs before the beam model: the string
    if model not in ("string", "beam"):
        raise ValueError(f"{path}: 'model' must be 'string' or 'beam', got {model!r}")
    csv_path = folder / "anchors.csv"
    data = read_moments(csv_path)  # ValueError: no such file, not a text file, file:line
    unknown = sorted(set(data) - set(anchors))
    if unknown:
        raise ValueError(f"{csv_path}: anchors {unknown} are not in {path} "
                         f"({sorted(anchors)})")
    status = summary.get("status", "completed")
    if status != "completed":
        log.warning("%s: the run's status is %r: comparing what it wrote", folder, status)
    kinks = read_kinks(folder)  # none without kinks.csv
    times = np.concatenate([d["time"] for d in list(data.values()) + list(kinks.values())])
    return {"dir": folder, "summary": summary, "anchors": anchors, "data": data,
            "kinks": kinks,
            "model": model, "status": status, "label": f"{model} ({folder.resolve().name})",
            "t_range": (float(times.min()), float(times.max()))}


def _num(x) -> float:
    """A JSON value as a float (None, missing, non-numbers: NaN)."""
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _pair(a, b) -> dict:
    """``{"a", "b", "rel_diff": (b - a) / a}`` (None where undefined)."""
    a, b = _num(a), _num(b)
    rel = (b - a) / a if math.isfinite(a) and math.isfinite(b) and a != 0 else math.nan
    return {"a": a, "b": b, "rel_diff": rel}


def _ratio(a, b) -> dict:
    """``{"a", "b", "ratio": b / a}`` (None where undefined)."""
    a, b = _num(a), _num(b)
    r = b / a if math.isfinite(a) and math.isfinite(b) and a > 0 else math.nan
    return {"a": a, "b": b, "ratio": r}


def _has_moments(run: dict, name: str) -> bool:
    d = run["data"].get(name)
    return (run["anchors"][name].get("kind") == "clamped" and d is not None
            and bool(np.any(np.isfinite(d["moment"]))))


def statistics_start(ra: dict, rb: dict) -> float | None:
    """The runs' common ``dynamics.statistics_start`` (from their echoed case files), None
    when either has none or they differ (then the last third of the common range)."""
    starts = []
    for r in (ra, rb):
        dyn = (r["summary"].get("case") or {}).get("dynamics") or {}
        starts.append(dyn.get("statistics_start") if isinstance(dyn, dict) else None)
    a, b = starts
    return float(a) if a is not None and b is not None and float(a) == float(b) else None


def _window_stats(times: np.ndarray, values: np.ndarray, t_lo: float, t_hi: float,
                  start: float | None = None) -> dict:
    """run.steady_state_stats over the common range ``[t_lo, t_hi]``: the samples outside
    are dropped and NaN samples at both ends of the range put in, so that the window
    (from ``start``, the runs' common ``dynamics.statistics_start``, when it lies in the
    range; else ``t >= t_hi - FRACTION (t_hi - t_lo)``) is the same for both runs (NaNs are
    skipped)."""
    sel = (times >= t_lo) & (times <= t_hi)
    t = np.concatenate([[t_lo], times[sel], [t_hi]])
    v = np.concatenate([[np.nan], values[sel], [np.nan]])
    return steady_state_stats(t, v, FRACTION, start=start)


def _trapezoid(t: np.ndarray, y: np.ndarray) -> float:
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t))) if t.size > 1 else 0.0


def history_error(ta: np.ndarray, ma: np.ndarray, tb: np.ndarray, mb: np.ndarray,
                  window: tuple[float, float]) -> dict:
    """``RMS(m_b - m_a) / RMS(m_a)`` over ``window``: the pointwise difference of two
    histories, relative to run a's (the reference of every relative difference here).

    The samples are run a's output times in the window (NaN samples of either run dropped);
    run b is linearly interpolated onto them when its times differ (error at most
    ``(omega dt_b)^2/8`` of the amplitude of a harmonic of frequency ``omega``; none when the
    grids agree, the usual case of two runs of the same case). Both mean squares are time
    integrals by the trapezoidal rule, ``RMS(f)^2 = (1/T) int f^2 dt``, exact for a harmonic
    history sampled uniformly over whole periods: a pure sinusoid shifted by a phase ``phi``
    gives ``2 |sin(phi/2)|``. Returns ``{"value", "samples", "interpolated"}`` (value NaN
    when undefined: fewer than 2 samples or a zero reference)."""
    fa, fb = np.isfinite(ma), np.isfinite(mb)
    ta, ma, tb, mb = ta[fa], ma[fa], tb[fb], mb[fb]
    lo, hi = window
    sel = (ta >= lo) & (ta <= hi)
    t, a = ta[sel], ma[sel]
    # b must cover the samples (no extrapolation)
    if tb.size:
        inside = (t >= tb[0]) & (t <= tb[-1])
        t, a = t[inside], a[inside]
    if t.size < 2 or tb.size < 1:
        return {"value": math.nan, "samples": int(t.size), "interpolated": False}
    same = np.isin(t, tb)
    interpolated = not bool(np.all(same))
    b = np.interp(t, tb, mb)
    ref = _trapezoid(t, a * a)
    val = math.sqrt(_trapezoid(t, (b - a) ** 2) / ref) if ref > 0 else math.nan
    return {"value": val, "samples": int(t.size), "interpolated": interpolated}


def start_warnings(run: dict, key: str, tol: float = START_TOLERANCE) -> list[dict]:
    """Warnings for the anchors whose first ``anchors.csv`` row differs from the static
    state in ``summary.json`` (tension, and the moment of a clamped anchor) by more than
    ``tol`` times the quantity's scale: the static value or, if larger, the run's peak.
    Only runs with more than one output time (a dynamic run)."""
    out = []
    for name, d in sorted(run["data"].items()):
        if d["time"].size < 2:
            continue
        entry = run["anchors"].get(name, {})
        checks = [("tension", "static_tension")]
        if _has_moments(run, name):
            checks.append(("moment", "static_moment"))
        for col, skey in checks:
            static, first = _num(entry.get(skey)), float(d[col][0])
            if not (math.isfinite(static) and math.isfinite(first)):
                continue
            vals = d[col][np.isfinite(d[col])]
            scale = max(abs(static), float(np.max(np.abs(vals))) if vals.size else 0.0)
            diff = first - static
            if scale > 0 and abs(diff) > tol * scale:
                rel = diff / static if static != 0 else math.nan
                out.append({
                    "run": key, "dir": str(run["dir"]), "anchor": name, "quantity": col,
                    "static": static, "first_row": first, "time": float(d["time"][0]),
                    "rel_diff": rel,
                    "message": (f"run {key} ({run['dir']}): anchor {name}: the first output "
                                f"row's {col} {first:.6g} (t = {d['time'][0]:.6g}) differs "
                                f"from the static {col} {static:.6g} by "
                                f"{abs(diff) / scale:.3g} of its scale (> {tol:g}): the run "
                                "did not start clean (an impulsive start?), its peaks and "
                                "early history include that start")})
    return out


# the comparison ------------------------------------------------------------------------------
def _drop_vertex_index(run: dict) -> None:
    """A network names its anchors ``group:i`` (the i-th vertex of the group): where a group
    has a single vertex, name it ``group``, as the single cable it can be compared with
    names its anchor."""
    groups = {}
    for name in run["anchors"]:
        group, sep, index = name.rpartition(":")
        if sep and index.isdigit():
            groups.setdefault(group, []).append(name)
    rename = {v[0]: g for g, v in groups.items()
              if len(v) == 1 and v[0] == f"{g}:0" and g not in run["anchors"]}
    for key in ("anchors", "data"):
        run[key] = {rename.get(n, n): v for n, v in run[key].items()}


def _compare(dir_a: Path, dir_b: Path, outdir: Path) -> dict:
    ra, rb = _read_run(dir_a), _read_run(dir_b)
    names_a, names_b = sorted(ra["anchors"]), sorted(rb["anchors"])
    if names_a != names_b:  # a network against the single cable it reduces to
        for r in (ra, rb):
            _drop_vertex_index(r)
        names_a, names_b = sorted(ra["anchors"]), sorted(rb["anchors"])
    if names_a != names_b:
        raise ValueError(f"the runs have different anchors: {dir_a} has {names_a}, {dir_b} "
                         f"has {names_b} (not the same case?)")
    clamped = [n for n in names_a if _has_moments(ra, n) and _has_moments(rb, n)]
    skipped = [n for n in names_a if n not in clamped
               and (ra["anchors"][n].get("kind") == "clamped"
                    or rb["anchors"][n].get("kind") == "clamped")]
    if not clamped and not set(ra["kinks"]) & set(rb["kinks"]):
        which = [str(r["dir"]) for r in (ra, rb)
                 if not any(_has_moments(r, n) for n in names_a)]
        none = (f" ({' and '.join(which)} {'has' if len(which) == 1 else 'have'} none)"
                if which else "")
        raise ValueError(f"no anchor is clamped with moments in both runs{none} and no "
                         "kink is in both: nothing to compare")
    for n in skipped:
        log.warning("anchor %s: not clamped with moments in both runs, left out", n)
    same = same_case(ra["summary"].get("case"), rb["summary"].get("case"))
    if not same:  # but for the keys the model choice sets (compare_kinks.MODEL_KEYS)
        log.warning("%s and %s echo different case files: is it the same case?", dir_a, dir_b)

    t_lo = max(ra["t_range"][0], rb["t_range"][0])
    t_hi = min(ra["t_range"][1], rb["t_range"][1])
    start = statistics_start(ra, rb)
    if start is not None and not t_lo <= start < t_hi:
        start = None  # outside the common range: the last third
    stats = functools.partial(_window_stats, start=start)
    steady = t_hi > t_lo
    if not steady:
        log.warning("the runs have no common time range longer than an instant (a: %s, b: "
                    "%s): steady state not compared", ra["t_range"], rb["t_range"])
    anchors = {}
    for n in clamped:
        sa, sb = ra["anchors"][n], rb["anchors"][n]
        entry = {"static_moment": _pair(sa.get("static_moment"), sb.get("static_moment")),
                 "static_tension": _pair(sa.get("static_tension"), sb.get("static_tension"))}
        window = None
        entry["history_error"] = {"value": math.nan, "samples": 0, "interpolated": False}
        if steady:
            st = [stats(r["data"][n]["time"], r["data"][n]["moment"], t_lo, t_hi)
                  for r in (ra, rb)]
            window = st[0]["window"]
            for key in ("peak", "rms", "mean"):
                entry[f"steady_{key}"] = _pair(st[0].get(key), st[1].get(key))
            da, db = ra["data"][n], rb["data"][n]
            entry["history_error"] = history_error(da["time"], da["moment"], db["time"],
                                                   db["moment"], tuple(window))
        else:
            for key in ("peak", "rms", "mean"):
                entry[f"steady_{key}"] = _pair(None, None)
        entry["window"] = window
        anchors[n] = entry

    def omega1(run):
        modes = run["summary"].get("modes")
        return modes[0].get("omega") if isinstance(modes, list) and modes and isinstance(
            modes[0], dict) else None

    warnings = start_warnings(ra, "a") + start_warnings(rb, "b")
    for w in warnings:
        log.warning("%s", w["message"])

    wall_a = ra["summary"].get("wall_time") or {}
    wall_b = rb["summary"].get("wall_time") or {}
    wall = {"total": _ratio(wall_a.get("total"), wall_b.get("total"))}
    if "dynamics" in wall_a or "dynamics" in wall_b:
        wall["dynamics"] = _ratio(wall_a.get("dynamics"), wall_b.get("dynamics"))

    result = {
        "cablefem": __version__, "command": "compare",
        "runs": {k: {"dir": str(r["dir"]), "model": r["model"], "label": r["label"],
                     "status": r["status"], "time_range": list(r["t_range"])}
                 for k, r in (("a", ra), ("b", rb))},
        "same_case": same,
        "common_time_range": [t_lo, t_hi] if steady else None,
        "steady_fraction": None if start is not None else FRACTION,
        "statistics_start": start,
        "anchors": anchors, "skipped_anchors": skipped,
        "kinks": compare_kinks(ra, rb, t_lo, t_hi, steady, stats, history_error,
                               _pair),
        "first_frequency": {"omega": _pair(omega1(ra), omega1(rb))},
        "wall_time": wall, "start_tolerance": START_TOLERANCE, "warnings": warnings}

    outdir.mkdir(parents=True, exist_ok=True)
    result["figures"] = _figures(outdir, ra, rb, anchors, t_lo, t_hi if steady else None)
    write_json(outdir / "compare.json", result, MPI.COMM_SELF)
    (outdir / "compare.md").write_text(_markdown(result))
    log.info("comparison of %s and %s written to %s", dir_a, dir_b, outdir)
    return jsonable(result)  # NaN -> None: the returned dict is compare.json's content


# output ------------------------------------------------------------------------------------
_ROWS = [("static_moment", "static moment"), ("static_tension", "static tension"),
         ("steady_peak", "steady-state peak |M|"), ("steady_rms", "steady-state RMS |M|")]


def _fmt(x) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.6g}"


def _pct(x) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{100 * x:+.2f} %"


def _table_rows(res: dict) -> list[list[str]]:
    """Rows ``[quantity, a, b, difference]`` of the comparison (a header row first)."""
    la, lb = res["runs"]["a"]["label"], res["runs"]["b"]["label"]
    rows = [["quantity", f"a: {la}", f"b: {lb}", "(b-a)/a or b/a"]]
    items = list(res["anchors"].items())
    items += [(f"kink {n}", e) for n, e in (res.get("kinks") or {}).items()]
    for name, entry in items:
        for key, text in _ROWS:
            if key not in entry:  # a kink has no static tension here
                continue
            p = entry[key]
            rows.append([f"{name}: {text}", _fmt(p["a"]), _fmt(p["b"]), _pct(p["rel_diff"])])
        h = entry.get("history_error") or {}
        v = h.get("value")
        rows.append([f"{name}: history error RMS(b-a)/RMS(a)", "", "",
                     "n/a" if v is None or not math.isfinite(v) else f"{100 * v:.2f} %"])
    p = res["first_frequency"]["omega"]
    rows.append(["first natural frequency omega (rad/s)", _fmt(p["a"]), _fmt(p["b"]),
                 _pct(p["rel_diff"])])
    for key, p in res["wall_time"].items():
        rows.append([f"wall time, {key} (s)", _fmt(p["a"]), _fmt(p["b"]),
                     "n/a" if p["ratio"] is None or not math.isfinite(p["ratio"])
                     else f"x {p['ratio']:.3g}"])
    return rows


def _window_text(res: dict) -> str:
    w = next((e["window"] for e in list(res["anchors"].values())
              + list((res.get("kinks") or {}).values()) if e["window"]), None)
    if w is None:
        return "steady state: not compared (no common time range)"
    which = ("from both runs' dynamics.statistics_start" if res.get("statistics_start")
             is not None else "the last third")
    return (f"steady state: t in [{w[0]:.6g}, {w[1]:.6g}], {which} of the common "
            f"time range [{res['common_time_range'][0]:.6g}, {res['common_time_range'][1]:.6g}]")


def _history_text(res: dict) -> str:
    interp = any((e.get("history_error") or {}).get("interpolated")
                 for e in res["anchors"].values())
    how = ("b interpolated linearly onto a's output times" if interp
           else "at a's output times (b has the same)")
    return ("history error: RMS of the pointwise difference |M|_b - |M|_a over the "
            f"steady-state window over the RMS of |M|_a, {how}")


def format_table(res: dict) -> str:
    """The comparison as an aligned plain-text table (what ``cablefem compare`` prints)."""
    rows = _table_rows(res)
    width = [max(len(r[i]) for r in rows) for i in range(4)]
    line = lambda r: "  ".join(c.ljust(w) if i == 0 else c.rjust(w)  # noqa: E731
                               for i, (c, w) in enumerate(zip(r, width))).rstrip()
    out = [line(rows[0]), "  ".join("-" * w for w in width)] + [line(r) for r in rows[1:]]
    out.append(_window_text(res))
    out.append(_history_text(res))
    if res.get("warnings"):
        out.append(f"warning: {len(res['warnings'])} first output row(s) differ from the "
                   "static state (the runs did not start clean): see compare.json 'warnings'")
    if res["skipped_anchors"]:
        out.append(f"not compared (not clamped with moments in both runs): "
                   f"{', '.join(res['skipped_anchors'])}")
    return "\n".join(out)


def _markdown(res: dict) -> str:
    a, b = res["runs"]["a"], res["runs"]["b"]
    rows = _table_rows(res)
    md = [f"# Comparison: {a['label']} vs {b['label']}", "",
          f"- a: `{a['dir']}` (model {a['model']}, status {a['status']})",
          f"- b: `{b['dir']}` (model {b['model']}, status {b['status']})",
          f"- {_window_text(res)}; moments are magnitudes |M|",
          f"- {_history_text(res)}",
          "- last column: relative difference (b-a)/a; wall times: ratio b/a", ""]
    if not res["same_case"]:
        md.insert(-1, "- **the runs echo different case files**")
    cells = lambda r: "| " + " | ".join(c.replace("|", "\\|") for c in r) + " |"  # noqa
    md += [cells(rows[0]), "|---|---:|---:|---:|"] + [cells(r) for r in rows[1:]]
    if res.get("warnings"):
        md += ["", "## Warnings", ""] + [f"- {w['message']}" for w in res["warnings"]]
    if res["skipped_anchors"]:
        md += ["", f"Not compared (not clamped with moments in both runs): "
                   f"{', '.join(res['skipped_anchors'])}."]
    return "\n".join(md) + "\n"


def _figure_name(anchor: str) -> str:
    return "compare_" + re.sub(r"[^A-Za-z0-9._-]", "_", anchor) + ".png"


def _figures(outdir: Path, ra: dict, rb: dict, anchors: dict, t_lo: float,
             t_hi: float | None) -> list[str]:
    """``compare_<anchor>.png``: |M| of both runs overlaid, and a zoom on the steady-state
    window (at most plots.MAX_PANELS anchors: those with the largest steady peak)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(anchors)
    if len(names) > MAX_PANELS:
        peak = {n: np.nan_to_num(_num(anchors[n]["steady_peak"]["a"])) for n in names}
        names = sorted(names, key=peak.get, reverse=True)[:MAX_PANELS]
        log.info("figures for the %d anchors with the largest steady-state moment",
                 MAX_PANELS)
    files = []
    for n in names:
        window = anchors[n]["window"]
        fig, axes = plt.subplots(2 if window else 1, 1, figsize=(9, 6 if window else 3.2),
                                 squeeze=False)
        for run, style in ((ra, dict(lw=0.9)), (rb, dict(lw=0.9, ls="--"))):
            d = run["data"][n]
            for ax in axes[:, 0]:
                ax.plot(d["time"], d["moment"], label=run["label"], **style)
        ax = axes[0, 0]
        ax.set_title(f"anchor {n}: moment magnitude |M|")
        if window:
            ax.axvspan(window[0], window[1], color="0.9", zorder=0,
                       label="steady-state window")
            zoom = axes[1, 0]
            zoom.set_xlim(window)
            vals = np.concatenate([r["data"][n]["moment"][(r["data"][n]["time"] >= window[0])
                                                         & (r["data"][n]["time"] <= window[1])]
                                   for r in (ra, rb)])
            vals = vals[np.isfinite(vals)]
            if vals.size:
                lo, hi = float(vals.min()), float(vals.max())
                pad = 0.05 * (hi - lo) if hi > lo else 0.05 * abs(hi) or 1.0
                zoom.set_ylim(lo - pad, hi + pad)
            zoom.set_title(f"steady state: t in [{window[0]:.4g}, {window[1]:.4g}] of the "
                           f"common time range [{t_lo:.4g}, {t_hi:.4g}]", fontsize=9)
        for ax in axes[:, 0]:
            ax.set_ylabel("|M|")
            ax.grid(True, lw=0.3)
            ax.legend(loc="upper left", fontsize=7)
        axes[-1, 0].set_xlabel("time t")
        fig.tight_layout()
        fname = _figure_name(n)
        fig.savefig(outdir / fname, dpi=110)
        plt.close(fig)
        files.append(fname)
    return files
