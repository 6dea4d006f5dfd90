"""Models built from Python objects (cablefem.create_cable, create_rod, create_network) are
the models of their case-file twins; bad arguments are CaseErrors naming the argument; the
case package does not load dolfinx and the core does not load the case or app packages."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import cablefem
from cablefem import (
    Anchor,
    CableSpec,
    CaseError,
    Damping,
    EllipseMotion,
    Gravity,
    HarmonicMotion,
    PointMass,
    Section,
    create_cable,
    create_network,
    create_rod,
    solve_static,
)
from cablefem.cable import CableModel
from cablefem.case import load_case, parse_case
from cablefem.rod import BeamModel

ROOT = Path(__file__).resolve().parents[1]
DEMOS = ROOT / "demos"
#: demos/stay_cable_si.toml's section (a 100 m steel stay)
STAY = Section(EA=8.7589e8, EI=1.962e5, GJ=0.0, mass=50.0, diameter=0.0756)


def _same_forces(a, b) -> None:
    """Static anchor forces of two models of one cable: the same mesh, the same forms and
    the same Newton iterations, so equal to round-off; 1e-9 of the largest force leaves
    room for a different summation order of the same numbers (rounding ~1e-16 per term,
    amplified by Newton's few iterations and the condition of the tangent, ~1e5 here)."""
    Fa, Fb = solve_static(a).anchor_forces, solve_static(b).anchor_forces
    scale = float(np.max(np.abs(Fa)))
    assert scale > 0
    np.testing.assert_allclose(Fa, Fb, rtol=0, atol=1e-9 * scale)


def test_stay_cable_from_python_equals_case_file():
    """demos/stay_cable_si.toml rebuilt with create_cable (anchors, section, length, the
    harmonic motion and the Rayleigh damping): same length and static anchor forces."""
    case = load_case(DEMOS / "stay_cable_si.toml")
    anchors = [Anchor("p", [0, 0, 0], "clamped", [1, 0, 0]),
               Anchor("q", [100.13333, 0, 0], "clamped", [-1, 0, 0],
                      HarmonicMotion([0.02, 0, 0], 10.2775, ramp=0.0))]
    model = create_cable(MPI.COMM_WORLD, anchors, STAY, length=100.0, elements=30,
                         gravity=Gravity(9.81, np.array([0.0, 0.0, -1.0])),
                         damping=Damping.from_ratios((0.005, 0.005), (5.1387, 10.2775)))
    twin = CableModel(MPI.COMM_WORLD, case)
    assert model.length == twin.length
    # the damping from ratios is the parser's (the same formula, rayleigh_coefficients)
    assert (model.case.damping.alpha, model.case.damping.beta) == \
        (case.damping.alpha, case.damping.beta)
    np.testing.assert_array_equal(model.anchors[1].displacement(0.3),
                                  twin.anchors[1].displacement(0.3))
    _same_forces(model, twin)


def _stay_dict(geometry: dict, **extra) -> dict:
    return {"section": {"EA": STAY.EA, "EI": STAY.EI, "mass": STAY.mass},
            "geometry": geometry, "mesh": {"elements": 24, "grading": 2.0},
            "anchors": [{"name": "low", "position": [0.0, 0, 0]},
                        {"name": "top", "type": "pinned", "position": [180.0, 0, 90.0]}],
            **extra}


@pytest.mark.parametrize("route", ["horizontal_tension", "sag_ratio", "polyline"])
def test_geometry_routes_equal_parse_case(route):
    """An inclined stay (clamped low anchor, pinned top) by tension H = 2 MN, by sag ratio
    1/50 and by a stress-free polyline (a kinked three-point line), with a point mass: the
    model of create_cable and that of parse_case have the same length and anchor forces."""
    poly = [[0.0, 0, 0], [90.0, 0, 40.0], [180.0, 0, 90.0]]
    value = {"horizontal_tension": 2e6, "sag_ratio": 0.02, "polyline": poly}[route]
    kw = {route: np.array(value) if route == "polyline" else value}
    anchors = [Anchor("low", [0.0, 0, 0]), Anchor("top", [180.0, 0, 90.0], "pinned")]
    model = create_cable(MPI.COMM_WORLD, anchors, Section(STAY.EA, STAY.EI, 0.0, STAY.mass),
                         elements=24, grading=2.0, point_masses=[PointMass(60.0, 500.0)],
                         **kw)
    twin = CableModel(MPI.COMM_WORLD, parse_case(_stay_dict(
        {route: value}, point_masses=[{"s": 60.0, "mass": 500.0}])))
    assert model.length == twin.length
    np.testing.assert_array_equal(model.anchors[0].direction, twin.anchors[0].direction)
    _same_forces(model, twin)


def test_fan_network_from_python_equals_case_file():
    """demos/fan.toml rebuilt with create_network (the mesh meshes/fan_small.msh, one
    section, six cable families, the pylon's elliptic motion): same stress-free length and
    static anchor forces (every anchor node of both groups)."""
    case = load_case(DEMOS / "fan.toml")
    pre = [2.5e6, 2.8e6, 3.1e6] * 2
    model = create_network(
        MPI.COMM_WORLD, ROOT / "meshes" / "fan_small.msh",
        {"stay": Section(9.07e8, 2.0e4, 0.0, 37.0, diameter=0.11)},
        [Anchor("pylon", motion=EllipseMotion(6.0, [0.02, 0, 0], [0, 0.01, 0],
                                              ramp=case.anchors[0].motion.ramp)),
         Anchor("deck")],
        cables=[CableSpec(f"stay_{i + 1:02d}", "stay", p) for i, p in enumerate(pre)],
        damping=Damping.from_ratios((0.005, 0.005), (6.0, 30.0)))
    twin = cablefem.model_from_case(MPI.COMM_WORLD, case)
    assert type(model) is type(twin)
    assert model.length == twin.length
    assert [a.name for a in model.anchors] == [a.name for a in twin.anchors]
    _same_forces(model, twin)


def test_rod_from_python_equals_case():
    """create_rod against BeamModel on the parsed twin (a short level cable, coarse rod
    mesh): same nodes and static anchor forces."""
    anchors = [Anchor("p", [0.0, 0, 0]), Anchor("q", [10.0, 0, 0])]
    sec = Section(1e7, 50.0, 0.0, 2.0)
    model = create_rod(MPI.COMM_WORLD, anchors, sec, horizontal_tension=2000.0,
                       span_elements=20, layer_elements=3.0, refine=0.5)
    twin = BeamModel(MPI.COMM_WORLD, parse_case({
        "section": {"EA": 1e7, "EI": 50.0, "mass": 2.0},
        "geometry": {"horizontal_tension": 2000.0},
        "beam": {"span_elements": 20, "layer_elements": 3.0},
        "anchors": [{"name": "p", "position": [0.0, 0, 0]},
                    {"name": "q", "position": [10.0, 0, 0]}]}), refine=0.5)
    np.testing.assert_array_equal(model.geometry.stations, twin.geometry.stations)
    _same_forces(model, twin)


def test_old_argument_order_is_refused():
    """CableModel(case, comm), the order of version 0.2, is refused since its shim went
    (a TypeError naming the order, before any work), for the string and the rod alike."""
    case = parse_case(_stay_dict({"length": 202.0}))
    assert CableModel(MPI.COMM_WORLD, case).length == pytest.approx(202.0, rel=1e-15)
    for cls in (CableModel, BeamModel):
        with pytest.raises(TypeError, match="comm, description"):
            cls(case, MPI.COMM_WORLD)
    with pytest.raises(TypeError, match="comm, description"):
        CableModel(MPI.COMM_WORLD, {"section": {}})


# --------------------------------------------------------------------------- bad arguments
_ANCHORS = [Anchor("p", [0.0, 0, 0]), Anchor("q", [100.0, 0, 0])]


@pytest.mark.parametrize("change,key", [
    ({"sag_ratio": -0.1, "length": None}, "sag_ratio"),
    ({"horizontal_tension": 1e6}, "length"),  # two geometries
    ({"length": None}, "length"),  # none
    ({"polyline": [[0, 0, 0], [0, 0, 0]], "length": None}, "polyline[1]"),
    ({"anchors": [Anchor("p", [0.0, 0, 0], "fixed"), _ANCHORS[1]]}, "anchors[0].kind"),
    ({"anchors": [_ANCHORS[0], Anchor("q", [0.0, 0, 0])]}, "anchors[1].position"),
    ({"anchors": [_ANCHORS[0]]}, "anchors"),
    ({"anchors": [_ANCHORS[0], Anchor("q", [1.0, 0, 0], "pinned", [1, 0, 0])]},
     "anchors[1].direction"),
    ({"anchors": [_ANCHORS[0], Anchor("q r", [1.0, 0, 0])]}, "anchors[1].name"),
    ({"section": {"EA": 1.0}}, "section"),
    ({"elements": 0}, "elements"),
    ({"grading": 0.5}, "grading"),
    ({"gravity": Gravity(-9.81)}, "gravity.g"),
    ({"point_masses": [PointMass(150.0, 10.0)]}, "point_masses[0].s"),
    ({"damping": Damping("viscous")}, "damping.model"),
    ({"outer_correction": "hinges"}, "outer_correction"),
    ({"tension_only": "yes"}, "tension_only"),
])
def test_bad_arguments_name_the_argument(change, key):
    """Each bad argument is one CaseError problem under the argument's name."""
    kw = {"length": 101.0, "anchors": _ANCHORS, "section": STAY, **change}
    kw = {k: v for k, v in kw.items() if v is not None}
    with pytest.raises(CaseError) as err:
        create_cable(MPI.COMM_WORLD, kw.pop("anchors"), kw.pop("section"), **kw)
    assert [k for k, _ in err.value.problems] == [key]


def test_bad_argument_messages_are_the_parsers():
    """The same bad value through create_cable and through a case: the same message (one
    check, cablefem.validation), under the argument's name and the key's path."""
    with pytest.raises(CaseError) as py:
        create_cable(MPI.COMM_WORLD, _ANCHORS, STAY, sag_ratio=12.0)
    with pytest.raises(CaseError) as toml:
        parse_case(_stay_dict({"sag_ratio": 12.0}))
    assert py.value.problems == [("sag_ratio", toml.value.problems[0][1])]
    assert toml.value.problems[0][0] == "geometry.sag_ratio"


def test_horizontal_tension_without_gravity_names_the_argument():
    with pytest.raises(CaseError) as err:
        create_cable(MPI.COMM_WORLD, _ANCHORS, STAY, horizontal_tension=1e6,
                     gravity=Gravity(0.0))
    assert err.value.problems == [("horizontal_tension", "needs gravity.g > 0 (got 0)")]


@pytest.mark.parametrize("change,key", [
    ({"mesh_file": ROOT / "meshes" / "nothing.msh"}, "mesh_file"),
    ({"cables": [CableSpec("stay_01", "strand", 1e6)]}, "cables[0].section"),
    ({"cables": [CableSpec("stay_01", "stay", -1.0)]}, "cables[0].pretension"),
    ({"anchors": [Anchor("pylon", [0.0, 0, 0])]}, "anchors[0].position"),
    ({"anchors": [Anchor("deck"), Anchor("deck")]}, "anchors[1].name"),
])
def test_bad_network_arguments_name_the_argument(change, key):
    kw = {"mesh_file": ROOT / "meshes" / "fan_small.msh",
          "sections": {"stay": STAY}, "anchors": [Anchor("pylon"), Anchor("deck")],
          "cables": [CableSpec("stay_01", "stay", 1e6)], **change}
    with pytest.raises(CaseError) as err:
        create_network(MPI.COMM_WORLD, kw.pop("mesh_file"), kw.pop("sections"),
                       kw.pop("anchors"), **kw)
    assert [k for k, _ in err.value.problems] == [key]


def test_bad_rod_arguments_name_the_argument():
    with pytest.raises(CaseError) as err:
        create_rod(MPI.COMM_WORLD, _ANCHORS, STAY, length=101.0, growth=3.0, refine=0.0)
    assert [k for k, _ in err.value.problems] == ["growth", "refine"]


# --------------------------------------------------------------------------- imports
_CORE = ["anchor", "description", "arguments", "validation", "properties", "motion",
         "timetables", "catenary", "asymptotics", "farfield", "moments", "cable", "network",
         "rod", "create", "statics", "modal", "dynamics", "reactions", "hinge", "fatigue",
         "forms", "geometry", "verify"]


@pytest.mark.serial
def test_imports_layering():
    """In a fresh interpreter: ``import cablefem.case`` (and the description objects) loads
    no dolfinx; importing every core module loads neither cablefem.case nor cablefem.app."""
    code = ("import sys, json, importlib\n"
            "import cablefem.case, cablefem.arguments, cablefem.anchor\n"
            "light = 'dolfinx' in sys.modules\n"
            "for m in sys.argv[1:]: importlib.import_module('cablefem.' + m)\n"
            "print(json.dumps([light, sorted(k for k in sys.modules if k.startswith("
            "('cablefem.case', 'cablefem.app')))]))\n")
    out = subprocess.run([sys.executable, "-c", code, *_CORE], capture_output=True,
                         text=True, check=True, cwd=ROOT).stdout
    light, loaded = json.loads(out.splitlines()[-1])
    assert light is False
    # cablefem.case was imported on purpose above; the core must add nothing of app
    assert [m for m in loaded if m.startswith("cablefem.app")] == []
    code2 = ("import sys, importlib\n"
             "for m in sys.argv[1:]: importlib.import_module('cablefem.' + m)\n"
             "print(sorted(k for k in sys.modules if k.startswith(('cablefem.case', "
             "'cablefem.app'))))\n")
    out2 = subprocess.run([sys.executable, "-c", code2, *_CORE], capture_output=True,
                          text=True, check=True, cwd=ROOT).stdout
    assert out2.split() == ["[]"]
