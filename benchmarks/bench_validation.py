"""Validation matrix: the string + asymptotics route against the project's converged rod.

For every case of the matrix, four runs of the command line (each a separate process):

* the string, by the route under test (``--outer-correction``, default: the case's own
  setting, that is the default route);
* the rod (``--model beam``), and the rod refined (``--refine 2``) and with the time step
  halved: the reference's own convergence, reported beside the comparison;

and ``cablefem compare`` of the rod (reference, ``a``) against the string (``b``): at every
clamped anchor the static moment, the steady-state peak and RMS of ``|M|`` (last third of the
run), the history error ``RMS(|M|_string - |M|_rod) / RMS(|M|_rod)`` over that window, the
first frequency, the wall times, and whether the string's run warned.

The matrix: the paper's cases A (parametric, in-plane) and B (the bending plane turns); an
inclined SI stay cable with clamps along the chord and a moving deck anchor; horizontal clamps
on a 10 %-sag cable (anchor angles of about 20-25 degrees) at eps = 0.005, 0.03 and 0.08,
the far anchor moving out of plane; a clamped-pinned cable; the stay cable as a network of two
cable families in line (the network's clamps, hinges included; its reference is the single
cable of the same stress-free length, and ``cablefem compare`` matches the network's anchor
``p:0`` with the cable's ``p``). Networks (issue 34), against the network rod on the same
case, every clamp and kink: the 2 x 2 saddle net of issue 34 (10 and 20 elements per bay),
a 5 x 5 saddle net, the 2 x 2 net with a damper between its two x cables, and a fan of
stays ending at a junction held by a hanger (the refined rod and the halved time step for
the 2 x 2 net only).

    python benchmarks/bench_validation.py [--cases A,B,...] [--outer-correction hinge]
        [--t-end-scale 1.0] [--json out.json] [--keep DIR]

Prints the JSON document and a Markdown table (for the README and docs/verification.md).
Aims (issue 12), for eps <= 0.03 and anchor angles up to 30 degrees: static within 0.5 %,
RMS within 1 %, peak within 2 %, history within 5 %; outside, the run's warnings fire.
Slow: every case runs the rod three times (several minutes each on one core).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEMOS = ROOT / "demos"


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(v)


def to_toml(data: dict, prefix: str = "") -> str:
    """A case dict as TOML (tables and arrays of tables; enough for case files)."""
    lines, tables, arrays = [], [], []
    for k, v in data.items():
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            arrays.append((k, v))
        else:
            lines.append(f"{k} = {_toml_value(v)}")
    out = "\n".join(lines) + ("\n" if lines else "")
    for k, v in tables:
        name = f"{prefix}{k}"
        out += f"\n[{name}]\n" + to_toml(v, name + ".")
    for k, items in arrays:
        name = f"{prefix}{k}"
        for item in items:
            sub = {a: b for a, b in item.items() if not isinstance(b, dict)}
            out += f"\n[[{name}]]\n" + to_toml(sub, name + ".")
            for a, b in item.items():
                if isinstance(b, dict):
                    out += f"\n[{name}.{a}]\n" + to_toml(b, f"{name}.{a}.")
    return out


def _demo(name: str) -> dict:
    return tomllib.loads((DEMOS / name).read_text())


def _sagging(eps: float) -> dict:
    """10 % sag (chord 0.974 l), clamped horizontally at both ends (anchor angles about
    0.4 rad), dimensionless (l = w = g = 1), anchor q moving out of plane below the first
    frequency (about 3.5)."""
    d = _demo("paper_inplane.toml")
    d["title"] = f"10 % sag, horizontal clamps, eps = {eps:g}, q moving out of plane"
    d["section"]["EI"] = eps**2
    d["anchors"][1]["position"] = [0.974, 0.0, 0.0]
    d["anchors"][1]["motion"] = {"type": "harmonic", "amplitude": [0.0, 0.01, 0.0],
                                 "omega": 2.5}
    d["damping"] = {"model": "rayleigh", "ratio": 0.01, "frequencies": [3.5, 7.0]}
    d["dynamics"].update({"t_end": 30.0, "dt": 0.005})
    return d


def _stay() -> dict:
    """An inclined 150 m stay cable (SI): deck anchor p moving vertically at 0.9 of the first
    frequency (about 5 rad/s), pylon anchor q, clamps along the chord."""
    return {
        "title": "Inclined SI stay cable, moving deck anchor",
        "section": {"EA": 1.5e9, "EI": 5.0e5, "mass": 60.0},
        "gravity": {"g": 9.81},
        "geometry": {"horizontal_tension": 3.0e6},
        "mesh": {"elements": 60},
        "anchors": [
            {"name": "p", "position": [0.0, 0.0, 0.0],
             "motion": {"type": "harmonic", "amplitude": [0.0, 0.0, 0.05], "omega": 4.5}},
            {"name": "q", "position": [130.0, 0.0, 75.0]}],
        "damping": {"model": "rayleigh", "ratio": 0.005, "frequencies": [5.0, 10.0]},
        "dynamics": {"t_end": 40.0, "dt": 0.01, "fields_every": 100},
    }


def _stay_network() -> dict:
    """The stay cable as a network of two cable families in line (24 + 36 elements on the
    chord, pretension 3.2e6 N): the network's code path at its clamps (hinges included),
    checked against the rod of the single cable it reduces to (same stress-free length)."""
    d = _stay()
    d["title"] = "Inclined SI stay cable as a two-member network, moving deck anchor"
    d.pop("geometry"), d.pop("mesh")
    sec = d.pop("section")
    d["sections"] = [{"name": "stay", **sec}]
    d["cables"] = [{"group": g, "section": "stay", "pretension": NET_PRETENSION}
                   for g in ("lower", "upper")]
    d["network"] = {"mesh": "net.msh"}
    for a in d["anchors"]:
        a.pop("position")
    return d


#: the network case's pretension (N) and elements per member
NET_PRETENSION, NET_ELEMENTS = 3.2e6, (24, 36)


def _network_files(data: dict, folder: Path) -> dict:
    """Write the network case's mesh (a straight chord from p to q, two cable families) and
    return the single-cable case of the same stress-free length for the rod."""
    import meshio
    import numpy as np

    p, q = np.array([0.0, 0.0, 0.0]), np.array([130.0, 0.0, 75.0])
    n = sum(NET_ELEMENTS)
    pts = p + np.linspace(0.0, 1.0, n + 1)[:, None] * (q - p)
    cells = np.column_stack([np.arange(n), np.arange(1, n + 1)])
    tags = np.array([1] * NET_ELEMENTS[0] + [2] * NET_ELEMENTS[1])
    field = {"lower": np.array([1, 1]), "upper": np.array([2, 1]),
             "p": np.array([101, 0]), "q": np.array([102, 0])}
    vtags = np.array([101, 102])
    mesh = meshio.Mesh(pts, [("line", cells), ("vertex", np.array([[0], [n]]))],
                       cell_data={"gmsh:physical": [tags, vtags],
                                  "gmsh:geometrical": [tags, vtags]}, field_data=field)
    meshio.write(folder / "net.msh", mesh, file_format="gmsh22", binary=False)
    sec = data["sections"][0]
    rod = _stay()
    rod["geometry"] = {"length": float(np.linalg.norm(q - p)) / (1.0 + NET_PRETENSION
                                                                 / sec["EA"])}
    rod["dynamics"] = data["dynamics"]
    return rod


def _roof_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_roof", ROOT / "meshes" / "make_roof.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _saddle(n: int = 2, k: int = 10, t_end: float = 15.0, start: float = 10.0,
            damper: bool = False) -> dict:
    """Issue 34's saddle net, n x n cables (meshes/make_roof.py, 40 m plan, 1 m saddle, k
    elements per bay), EA = 2e8 N, EI = 2e3 N m², 10 kg/m, pretension 1e5 N, gravity,
    clamped edges; 3 kN at 12 rad/s on the first crossing, 1 % Rayleigh at 12 and 17.16
    rad/s; statistics from ``start``. ``damper``: a dashpot (5e3 N s/m, vertical) between
    the two x cables at the middle of their middle bay (n = 2, k even)."""
    d = tomllib.loads((DEMOS / "saddle_2x2.toml").read_text())
    d["title"] = f"saddle net {n} x {n}, {k} elements per bay" + (", damper" if damper else "")
    d["network"]["mesh"] = "net.msh"
    d["dynamics"].update({"t_end": t_end, "statistics_start": start})

    def files(data: dict, folder: Path):
        import meshio
        import numpy as np

        m = _roof_module().roof(n, k, 40.0, 1.0, load_node=True)
        if damper:  # the middle of the middle bay of each x cable (y = -20/3, +20/3)
            pts = np.asarray(m.points)
            ends = [int(np.argmin(np.hypot(pts[:, 0], pts[:, 1] - y))) for y in (-20 / 3, 20 / 3)]
            line, vert = m.cells[0].data, m.cells[1].data
            tags = [m.cell_data["gmsh:physical"][0], m.cell_data["gmsh:physical"][1]]
            line = np.vstack([line, [ends]])
            tags[0] = np.append(tags[0], 40)
            field = dict(m.field_data, tie=np.array([40, 1]))
            m = meshio.Mesh(pts, [("line", line), ("vertex", vert)],
                            cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
                            field_data=field)
        meshio.write(folder / "net.msh", m, file_format="gmsh22", binary=False)
        return None  # the rod runs the same case

    if damper:
        d["dampers"] = [{"group": "tie", "coefficient": 5.0e3, "direction": [0.0, 0.0, 1.0]}]
    d["_files"] = files
    return d


def _fan_junction(elements: int = 20) -> dict:
    """Four stays from clamped deck anchors (x = ±15, ±35 m, z = 0) ending at a junction
    node (0, 0, 40 m) held by a fifth cable from a clamped anchor 20 m above: every cable
    ends at the junction (a pinned tie, no kink). EA = 2e8 N, EI = 2e3 N m², 10 kg/m,
    stays pretensioned 2e5 N, the hanger the sum of their vertical pulls (the mesh is in
    equilibrium without gravity); gravity, the outer deck anchors moving vertically at
    3 rad/s (2 cm), 1 % Rayleigh at 3 and 10 rad/s, 20 s, statistics from 10 s."""
    import numpy as np

    head, top = np.array([0.0, 0.0, 40.0]), np.array([0.0, 0.0, 60.0])
    decks = [np.array([x, 0.0, 0.0]) for x in (-35.0, -15.0, 15.0, 35.0)]
    T = 2.0e5
    hanger = float(sum(T * (head - p)[2] / np.linalg.norm(head - p) for p in decks))
    d = {"title": "fan of four stays ending at a junction, held by a hanger",
         "network": {"mesh": "net.msh"},
         "sections": [{"name": "strand", "EA": 2.0e8, "EI": 2.0e3, "mass": 10.0}],
         "cables": [{"group": f"stay{i}", "section": "strand", "pretension": T}
                    for i in range(4)]
         + [{"group": "hanger", "section": "strand", "pretension": hanger}],
         "gravity": {"g": 9.81},
         "anchors": [{"name": "deck_out", "motion": {"type": "harmonic",
                                                     "amplitude": [0.0, 0.0, 0.02],
                                                     "omega": 3.0}},
                     {"name": "deck_in"}, {"name": "top"}],
         "damping": {"ratio": 0.01, "frequencies": [3.0, 10.0]},
         "dynamics": {"t_end": 20.0, "dt": 0.005, "fields_every": 200,
                      "statistics_start": 10.0},
         "modal": {"modes": 4}}

    def files(data: dict, folder: Path):
        import meshio

        pts, cells, tags, end = [head], [], [], []
        for i, p in enumerate(decks + [top]):  # each cable from the junction (node 0)
            first = len(pts)
            pts += [head + (p - head) * j / elements for j in range(1, elements + 1)]
            ids = [0] + list(range(first, first + elements))
            cells += [[ids[j], ids[j + 1]] for j in range(elements)]
            tags += [i + 1] * elements
            end.append(ids[-1])  # its anchor
        field = {f"stay{i}": np.array([i + 1, 1]) for i in range(4)}
        field.update({"hanger": np.array([5, 1]), "deck_out": np.array([10, 0]),
                      "deck_in": np.array([11, 0]), "top": np.array([12, 0])})
        vert = np.array([[end[0]], [end[3]], [end[1]], [end[2]], [end[4]]])
        vtags = np.array([10, 10, 11, 11, 12])
        tags = np.array(tags)
        m = meshio.Mesh(np.array(pts), [("line", np.array(cells)), ("vertex", vert)],
                        cell_data={"gmsh:physical": [tags, vtags],
                                   "gmsh:geometrical": [tags, vtags]}, field_data=field)
        meshio.write(folder / "net.msh", m, file_format="gmsh22", binary=False)
        return None

    d["_files"] = files
    return d


def _clamped_pinned() -> dict:
    d = _demo("paper_inplane.toml")
    d["title"] = "Case A with anchor q pinned"
    d["anchors"][1]["type"] = "pinned"
    d["anchors"][1].pop("direction", None)
    return d


CASES = {
    "A": ("paper case A: in-plane, parametric (eps 0.02)", lambda: _demo("paper_inplane.toml")),
    "B": ("paper case B: the bending plane turns (eps 0.02)",
          lambda: _demo("paper_spatial.toml")),
    "stay": ("inclined SI stay cable, moving deck anchor", _stay),
    "sag005": ("10 % sag, horizontal clamps, eps 0.005", lambda: _sagging(0.005)),
    "sag03": ("10 % sag, horizontal clamps, eps 0.03", lambda: _sagging(0.03)),
    "sag08": ("10 % sag, horizontal clamps, eps 0.08", lambda: _sagging(0.08)),
    "clamped_pinned": ("case A, q pinned", _clamped_pinned),
    "network": ("the stay cable as a two-member network (its clamps)", _stay_network),
    "net2x2": ("issue 34's 2 x 2 saddle net, 10 elements per bay", _saddle),
    "net2x2_k20": ("the 2 x 2 saddle net, 20 elements per bay", lambda: _saddle(k=20)),
    "net5x5": ("a 5 x 5 saddle net, 10 elements per bay (6 s)",
               lambda: _saddle(5, 10, 6.0, 3.0)),
    "net_damper": ("the 2 x 2 saddle net with a damper between its x cables",
                   lambda: _saddle(damper=True)),
    "fan_junction": ("four stays and a hanger ending at a junction", _fan_junction),
}

#: the network cases: the reference is the network rod on the same case (every clamp and
#: kink compared); the refined rod and the halved time step only for these
NETWORK_CONVERGENCE = ("net2x2",)


def _run(case_file: Path, out: Path, *extra: str) -> dict:
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "cablefem", "run", str(case_file), "--output",
                          str(out), "--no-figures", "-q", *extra],
                         capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    summary = {}
    if (out / "summary.json").is_file():
        summary = json.loads((out / "summary.json").read_text())
    # each clamp's and kink's history_error_estimate (docs/theory.md §5.4), beside the
    # measured history error in the table
    estimates = {n: a["history_error_estimate"] for n, a in summary.get("anchors", {}).items()
                 if "history_error_estimate" in a}
    estimates.update({f"kink {n}": k["history_error_estimate"]
                      for n, k in (summary.get("kinks") or {}).items()
                      if "history_error_estimate" in k})
    return {"exit": res.returncode, "wall_s": wall, "stderr": res.stderr[-2000:],
            "warnings": summary.get("warnings", []), "history_estimates": estimates}


def _compare(ref: Path, other: Path, out: Path) -> dict:
    from cablefem.app.compare import compare_runs

    return compare_runs(ref, other, out)


def _rel(pair: dict | None) -> float | None:
    if not pair:
        return None
    v = pair.get("rel_diff")
    return None if v is None or (isinstance(v, float) and math.isnan(v)) else v


def _digest(cmp: dict) -> dict:
    """Relative differences (other - reference) / reference per clamped anchor."""
    out = {}
    for name, e in cmp["anchors"].items():
        out[name] = {
            "static_moment": _rel(e.get("static_moment")),
            "steady_peak": _rel(e.get("steady_peak")),
            "steady_rms": _rel(e.get("steady_rms")),
            "history_error": e["history_error"]["value"],
            "rod_static_moment": e["static_moment"]["a"],
            "rod_steady_rms": (e.get("steady_rms") or {}).get("a")}
    for name, e in (cmp.get("kinks") or {}).items():
        out[f"kink {name}"] = {
            "static_moment": _rel(e.get("static_moment")),
            "steady_peak": _rel(e.get("steady_peak")),
            "steady_rms": _rel(e.get("steady_rms")),
            "history_error": (e.get("history_error") or {}).get("value"),
            "rod_static_moment": (e.get("static_moment") or {}).get("a"),
            "rod_steady_rms": (e.get("steady_rms") or {}).get("a")}
    out["first_frequency"] = _rel(cmp["first_frequency"]["omega"])
    return out


def run_case(key: str, work: Path, correction: str | None, t_scale: float,
             rod_convergence: bool = True) -> dict:
    title, make = CASES[key]
    data = make()
    files = data.pop("_files", None)
    data["dynamics"]["t_end"] = data["dynamics"]["t_end"] * t_scale
    if "statistics_start" in data["dynamics"]:
        data["dynamics"]["statistics_start"] *= t_scale
    folder = work / key
    folder.mkdir(parents=True, exist_ok=True)
    case_file = folder / "case.toml"
    case_file.write_text(to_toml(data))
    half = json.loads(json.dumps(data))
    half["dynamics"]["dt"] = data["dynamics"]["dt"] / 2.0
    half["dynamics"]["output_every"] = 2 * data["dynamics"].get("output_every", 1)
    half["dynamics"]["fields_every"] = 2 * data["dynamics"].get("fields_every", 50)
    half_file = folder / "case_half_dt.toml"
    half_file.write_text(to_toml(half))
    rod_file, rod_half_file = case_file, half_file
    if files is not None:  # a network: its mesh; the rod runs the same case
        files(data, folder)
    elif "network" in data:  # the rod takes the single cable the network reduces to
        rod = _network_files(data, folder)
        rod_half = json.loads(json.dumps(rod))
        rod_half["dynamics"] = half["dynamics"]
        rod_file, rod_half_file = folder / "rod_case.toml", folder / "rod_case_half_dt.toml"
        rod_file.write_text(to_toml(rod))
        rod_half_file.write_text(to_toml(rod_half))
    routes = correction.split(",") if correction else [None]
    runs = {f"string_{r or 'default'}": _run(case_file, folder / f"string_{r or 'default'}",
                                             *(["--outer-correction", r] if r else []))
            for r in routes}
    runs["rod"] = _run(rod_file, folder / "rod", "--model", "beam")
    if rod_convergence and (files is None or key in NETWORK_CONVERGENCE):
        runs.update({
            "rod_refined": _run(rod_file, folder / "rod_refined", "--model", "beam",
                                "--refine", "2"),
            "rod_half_dt": _run(rod_half_file, folder / "rod_half_dt", "--model", "beam")})
    strings = [k for k in runs if k.startswith("string_")]
    entry = {"title": title, "runs": {k: {kk: v[kk] for kk in ("exit", "wall_s")}
                                      for k, v in runs.items()},
             "string_warnings": {k: [w.get("message") for w in runs[k]["warnings"]]
                                 for k in strings},
             "string_history_estimates": {k: runs[k]["history_estimates"] for k in strings}}
    failed = [k for k, v in runs.items() if v["exit"] != 0]
    if failed:  # said in the table; what did run is still compared
        entry["failed"] = {k: runs[k]["stderr"] for k in failed}
    if "rod" in failed:
        return entry
    entry["string_vs_rod"] = {k[len("string_"):]: _digest(_compare(folder / "rod", folder / k,
                                                                  folder / f"cmp_{k}"))
                              for k in strings if k not in failed}
    for key, run in (("rod_refinement", "rod_refined"), ("rod_half_dt", "rod_half_dt")):
        if run in runs and run not in failed:
            entry[key] = _digest(_compare(folder / "rod", folder / run, folder / f"cmp_{run}"))
    entry["wall_ratio_rod_over_string"] = {k[len("string_"):]: runs["rod"]["wall_s"]
                                            / runs[k]["wall_s"] for k in strings
                                            if k not in failed}
    return entry


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:+.2f} %"


def table(results: dict) -> str:
    rows = ["| case | route | anchor | static | peak | RMS | history | history estimate | "
            "omega1 | rod: refine / dt/2 (RMS) | warned |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for key, e in results.items():
        if "string_vs_rod" not in e:
            rows.append(f"| {key} | - | - | failed: {', '.join(e.get('failed', {}))} "
                        "||||||")
            continue
        r, h = e.get("rod_refinement"), e.get("rod_half_dt")
        for k in e.get("failed", {}):
            if k.startswith("string_"):
                rows.append(f"| {key} | {k[len('string_'):]} | - | the run failed "
                            "(see the JSON) ||||||")
        for route, d in e["string_vs_rod"].items():
            scale = max((abs(v.get("rod_static_moment") or 0.0) for k, v in d.items()
                         if k != "first_frequency"), default=0.0)
            for name, a in d.items():
                if name == "first_frequency":
                    continue
                if abs(a.get("rod_static_moment") or 0.0) < 1e-9 * scale:
                    # a clamp along its cable's line of force (a hanger): no moment in
                    # either model, the relative differences of round-off say nothing
                    rows.append(f"| {key} | {route} | {name} | zero in both |||||||||")
                    continue
                conv = (f"{_pct(r[name]['steady_rms']) if r else '-'} / "
                        f"{_pct(h[name]['steady_rms']) if h else '-'}")
                hist = a["history_error"]
                hist_text = "-" if hist is None or hist != hist else f"{100 * hist:.1f} %"
                warned = "yes" if e["string_warnings"][f"string_{route}"] else "no"
                est = e.get("string_history_estimates", {}).get(f"string_{route}", {}).get(name)
                est_text = "-" if est is None else f"{100 * est:.1f} %"
                rows.append(f"| {key} | {route} | {name} | {_pct(a['static_moment'])} | "
                            f"{_pct(a['steady_peak'])} | {_pct(a['steady_rms'])} | "
                            f"{hist_text} | {est_text} | {_pct(d['first_frequency'])} | "
                            f"{conv} | {warned} |")
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=",".join(CASES),
                    help=f"comma-separated subset of {', '.join(CASES)}")
    ap.add_argument("--outer-correction", default=None,
                    help="the string's route(s), comma-separated from none, hinge (default: "
                         "each case's own setting, i.e. the default route)")
    ap.add_argument("--t-end-scale", type=float, default=1.0,
                    help="scale every case's t_end (shorter runs for a quick look)")
    ap.add_argument("--no-rod-convergence", action="store_true",
                    help="skip the refined rod and the halved time step (the reference's "
                         "own convergence, reported beside the comparison)")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--keep", type=Path, default=None, help="keep the run folders here")
    args = ap.parse_args()
    keys = [k.strip() for k in args.cases.split(",") if k.strip()]
    unknown = [k for k in keys if k not in CASES]
    if unknown:
        ap.error(f"unknown case(s) {unknown}; known: {list(CASES)}")
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        results = {k: run_case(k, work, args.outer_correction, args.t_end_scale,
                               not args.no_rod_convergence) for k in keys}
    doc = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "machine": platform.machine(), "python": platform.python_version(),
           "outer_correction": args.outer_correction or "case default",
           "t_end_scale": args.t_end_scale, "cases": results}
    text = json.dumps(doc, indent=2)
    if args.json:
        args.json.write_text(text)
    print(text)
    print()
    print(table(results))


if __name__ == "__main__":
    main()
