"""Valid but physically implausible input: the static catenary's strain and stress-free
length are checked when the model is built, and reported as run warnings (summary.json
'warnings'; 'cablefem run --strict' exits 3)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from mpi4py import MPI

from cablefem.app.run import run_case
from cablefem.cable import MAX_PLAUSIBLE_STRAIN, PLAUSIBLE_LENGTH_RATIO, CableModel
from cablefem.case import parse_case

EA, MASS, G, CHORD = 8.7589e8, 50.0, 9.81, 200.0  # a 200 m steel stay (stay_cable_si.toml)


def stay(geometry: dict) -> dict:
    return {"title": "stay", "section": {"EA": EA, "EI": 1.962e5, "mass": MASS},
            "gravity": {"g": G}, "geometry": geometry, "mesh": {"elements": 20},
            "anchors": [{"name": "p", "position": [0.0, 0, 0]},
                        {"name": "q", "position": [CHORD, 0, 0]}]}


def keys_and_messages(warnings):
    return [(k, m) for k, m in warnings]


@pytest.mark.parametrize("geometry,key,what", [
    # H = 4e12 N: strain H/EA = 4566 and l ~ chord/(1 + H/EA) = 0.044 m
    ({"horizontal_tension": 4e12}, "geometry.horizontal_tension", ("strain", "length")),
    # l = chord/2: the cable must stretch by 100 % to span the chord
    ({"length": 0.5 * CHORD}, "geometry.length", ("strain", "length")),
    # sag 4 chords: l is about 8.2 chords (strain tiny: w l^2 / EA)
    ({"sag_ratio": 4.0}, "geometry.sag_ratio", ("length",)),
])
def test_implausible_catenary_warns(geometry, key, what):
    """The largest static strain T/EA above MAX_PLAUSIBLE_STRAIN, or a stress-free length
    outside PLAUSIBLE_LENGTH_RATIO of the chord: a warning naming the geometry key; a
    normal stay (H = 1e6 N: strain ~1e-3, l within 1 % of the chord: the stretch H l/EA
    and the sag's extra length 8 d^2/(3 l) are both ~1e-3 l) has none."""
    model = CableModel(MPI.COMM_WORLD, parse_case(stay(geometry)))
    strain = model.force_scale / EA  # the largest catenary tension (or the weight) / EA
    ratio = model.length / CHORD
    expect = set()
    if strain > MAX_PLAUSIBLE_STRAIN:
        expect.add("strain")
    if not PLAUSIBLE_LENGTH_RATIO[0] <= ratio <= PLAUSIBLE_LENGTH_RATIO[1]:
        expect.add("length")
    assert expect == set(what)
    got = keys_and_messages(model.warnings)
    assert {k for k, _ in got} == {key}
    assert ("strain" in what) == any("strain" in m for _, m in got)
    assert ("length" in what) == any("stress-free length" in m for _, m in got)
    normal = CableModel(MPI.COMM_WORLD, parse_case(stay({"horizontal_tension": 1e6})))
    assert normal.warnings == []
    assert 0.99 < normal.length / CHORD < 1.01 and normal.force_scale / EA < 2e-3


def test_implausible_case_warns_in_summary(mpi_tmp_path):
    """run_case lists the model's warnings in summary.json (all ranks the same)."""
    res = run_case(parse_case(stay({"horizontal_tension": 4e12})), mpi_tmp_path / "bad",
                   dynamics=False, modes=0, figures=False, progress=False)
    assert res.summary["warnings"] and all(w["key"] == "geometry.horizontal_tension"
                                           for w in res.summary["warnings"])
    saved = json.loads((mpi_tmp_path / "bad" / "summary.json").read_text())
    assert saved["warnings"] == json.loads(json.dumps(res.summary["warnings"]))
    assert MPI.COMM_WORLD.allgather(len(saved["warnings"])) == [2] * MPI.COMM_WORLD.size
    res = run_case(parse_case(stay({"horizontal_tension": 1e6})), mpi_tmp_path / "good",
                   dynamics=False, modes=0, figures=False, progress=False)
    assert res.summary["warnings"] == []


@pytest.mark.serial  # subprocesses: not under mpirun
def test_strict_exits_3_on_implausible_input(tmp_path):
    """'cablefem run --strict' exits 3 on the absurd horizontal tension (and says where the
    warnings are), 0 on the normal stay."""
    for name, h, code in (("bad", 4e12, 3), ("good", 1e6, 0)):
        case = tmp_path / f"{name}.toml"
        case.write_text(f"""title = "stay"
[section]
EA = {EA!r}
EI = 1.962e5
mass = {MASS!r}
[gravity]
g = {G!r}
[geometry]
horizontal_tension = {h!r}
[mesh]
elements = 20
[[anchors]]
name = "p"
position = [0, 0, 0]
[[anchors]]
name = "q"
position = [{CHORD!r}, 0, 0]
""")
        out = tmp_path / name
        res = subprocess.run([sys.executable, "-m", "cablefem", "run", str(case), "--output",
                              str(out), "--static-only", "--strict", "--no-figures", "-q"],
                             capture_output=True, text=True, timeout=300)
        assert res.returncode == code, res.stderr
        warnings = json.loads((out / "summary.json").read_text())["warnings"]
        assert bool(warnings) == (code == 3)
        if code == 3:
            assert "summary.json" in res.stderr and all(
                w["key"] == "geometry.horizontal_tension" for w in warnings)
            assert any(f"{100 * MAX_PLAUSIBLE_STRAIN:g} %" in w["message"] for w in warnings)
