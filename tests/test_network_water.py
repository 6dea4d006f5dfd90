"""Networks in water: Morison drag, buoyancy and added mass on every cable with its own
section's diameter, and a seabed (runs serially and under mpirun -n 2)."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from test_network import write_mesh

from cablefem.cable import CableModel
from cablefem.case import CaseError, parse_case
from cablefem.dynamics import integrate
from cablefem.network import NetworkModel
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
RHO, G = 1025.0, 9.81
CHAIN = {"EA": 5.5e8, "EI": 4.0e4, "mass": 30.0, "diameter": 0.076}
# the fairlead of a 400 m line from an anchor on the seabed whose stress-free polyline is
# 31 elements of 10 m along the seabed, then 9 straight up to it: (x - 310)^2 + 80^2 = 90^2
FAIRLEAD = [310.0 + np.sqrt(1700.0), 0.0, -20.0]
ANCHOR = [0.0, 0.0, -100.0]
FLUID = {"density": RHO, "surface": 0.0, "current": [0.5, 0.0, 0.0],
         "profile": {"type": "power", "ground": -100.0, "reference": 100.0,
                     "exponent": 1 / 7},
         "waves": [{"height": 4.0, "period": 10.472, "direction": [1.0, 0.0, 0.0]}],
         "wave_ramp": 2.0}
SEABED = {"z": -100.0, "stiffness": 1.0e5, "damping": 2.0e3, "friction": 0.5}
FAIRLEAD_DIR = [-0.2052, 0.0, -0.9787]
MOTION = {"type": "harmonic", "amplitude": [2.0, 0.0, 0.0], "omega": 0.6}


def mooring_single() -> dict:
    return {"title": "line", "section": CHAIN, "gravity": {"g": G},
            "geometry": {"length": 400.0}, "mesh": {"elements": 40},
            "anchors": [{"name": "anchor", "position": ANCHOR, "type": "pinned"},
                        {"name": "fairlead", "position": FAIRLEAD,
                         "direction": FAIRLEAD_DIR, "motion": MOTION}],
            "fluid": FLUID, "seabed": SEABED, "solver": {"outer_correction": "none"}}


def mooring_network(path) -> dict:
    """The same line as a network: its mesh the stress-free L-shaped polyline of 40
    elements of 10 m (pretension 0: stress-free as meshed)."""
    pts = [[10.0 * i, 0.0, -100.0] for i in range(32)]
    top = np.asarray(FAIRLEAD)
    for i in range(1, 10):
        pts.append((np.asarray(pts[31]) + i / 9 * (top - pts[31])).tolist())
    cells = np.column_stack([np.arange(40), np.arange(1, 41)])
    mesh = write_mesh(str(path / "line.msh"), pts, cells, ["line"] * 40,
                      {"anchor": [0], "fairlead": [40]})
    return {"title": "line", "network": {"mesh": mesh},
            "sections": [{"name": "chain", **CHAIN}],
            "cables": [{"group": "line", "section": "chain", "pretension": 0.0}],
            "gravity": {"g": G},
            "anchors": [{"name": "anchor", "type": "pinned"},
                        {"name": "fairlead", "direction": FAIRLEAD_DIR, "motion": MOTION}],
            "fluid": FLUID, "seabed": SEABED, "solver": {"outer_correction": "none"}}


def test_mooring_line_as_a_network_equals_the_single_cable(mpi_tmp_path):
    """A catenary mooring line (400 m, 40 elements) from an anchor on the seabed to a
    surging fairlead, in a sheared current with a swell, on a seabed with damping and
    friction: built as a network (from a stress-free L-shaped mesh) it solves the same
    discrete equations as the single cable (from the grounded catenary), so the static
    anchor forces and the anchor forces over 2 s of dynamics agree to Newton's tolerance
    (1e-8 of the fairlead tension). Before, a network case refused [fluid] and [seabed]."""
    single = CableModel(comm, parse_case(mooring_single()))
    net = NetworkModel(comm, parse_case(mooring_network(mpi_tmp_path)))
    F = [solve_static(m).anchor_forces[:, :3] for m in (single, net)]
    scale = np.abs(F[0]).max()
    np.testing.assert_allclose(F[1], F[0], rtol=0, atol=1e-8 * scale)
    hist = [np.array([f[:, :3] for _, f in integrate(m, 2.0, 0.05)]) for m in (single, net)]
    np.testing.assert_allclose(hist[1], hist[0], rtol=0, atol=1e-8 * scale)
    # the line moved: the swell and the surge change the fairlead force
    assert np.ptp(hist[0][:, 1, 0]) > 1e-3 * scale


def test_each_cable_has_its_sections_diameter(mpi_tmp_path):
    """A horizontal line of two cables in series (60 m each, diameters 0.05 and 0.2 m,
    sections of the same mass) across a uniform current U = 1 m/s, fully immersed, no
    fluid.diameter: the anchors carry, exactly (an equilibrium of the discrete equations,
    to Newton's tolerance), the weight less the buoyancy rho g pi D^2/4 per current length
    and the drag 1/2 rho C_dn D |U_n| U_n (+ the tangential part) per current length of
    each element, from the elements of the solution: 1e-8."""
    n = 12
    x = np.linspace(0.0, 120.0, 2 * n + 1)
    pts = np.column_stack([x, 0 * x, 0 * x])
    cells = np.column_stack([np.arange(2 * n), np.arange(1, 2 * n + 1)])
    mesh = write_mesh(str(mpi_tmp_path / "two.msh"), pts, cells,
                      ["thin"] * n + ["thick"] * n, {"ends": [0, 2 * n]})
    sec = {"EA": 1.0e8, "EI": 1.0e3, "mass": 40.0}
    D = {"thin": 0.05, "thick": 0.2}
    fluid = {"density": RHO, "current": [0.0, 1.0, 0.0], "cd_normal": 1.2,
             "cd_tangential": 0.008}
    d = {"title": "two", "network": {"mesh": mesh},
         "sections": [{"name": g, **sec, "diameter": D[g]} for g in D],
         "cables": [{"group": g, "section": g, "pretension": 2.0e4} for g in D],
         "gravity": {"g": G}, "anchors": [{"name": "ends", "type": "pinned"}],
         "fluid": fluid}
    model = NetworkModel(comm, parse_case(d))
    st = solve_static(model)
    r = model.gather_nodal(model.u)
    total = None
    if comm.rank == 0:
        r = r + pts
        total = np.zeros(3)
        for e, (a, b) in enumerate(cells):
            Dg = D["thin"] if e < n else D["thick"]
            seg = r[b] - r[a]
            ell = np.linalg.norm(seg)
            t = seg / ell
            h = 5.0 / (1 + 2.0e4 / sec["EA"])  # stress-free element length
            U = np.array([0.0, 1.0, 0.0])
            Ut = (U @ t) * t
            Un = U - Ut
            drag = 0.5 * RHO * (1.2 * Dg * np.sqrt(Un @ Un + 1e-8) * Un
                                + 0.008 * np.pi * Dg * np.sqrt(Ut @ Ut + 1e-8) * Ut)
            buoy = RHO * G * np.pi * Dg**2 / 4
            total += (drag + np.array([0, 0, buoy])) * ell + np.array([0, 0, -sec["mass"] * G * h])
    total = comm.bcast(total, root=0)
    # the forces on the anchors are the loads on the cables
    np.testing.assert_allclose(st.anchor_forces[:, :3].sum(axis=0), total, rtol=0,
                               atol=1e-8 * np.abs(total).max())
    # and the thick cable's drag is what makes the difference: 4x the thin one's
    assert abs(total[1]) > 0.5 * 1.2 * 0.5 * RHO * 0.2 * 60.0


def test_a_network_fluid_needs_a_diameter(mpi_tmp_path):
    """[fluid] on a network without fluid.diameter needs every section a cable uses to
    have its diameter: refused naming fluid.diameter and the sections without one."""
    d = mooring_network(mpi_tmp_path)
    d["sections"][0] = {k: v for k, v in d["sections"][0].items() if k != "diameter"}
    with pytest.raises(CaseError, match=r"fluid\.diameter.*chain"):
        parse_case(d)
    d["fluid"] = {**FLUID, "diameter": 0.076}
    parse_case(d)


def test_network_touchdown_history_equals_the_single_cable(mpi_tmp_path):
    """touchdown.csv of the mooring line run as a network (rows named by the cable group)
    and as the single cable: the same touchdown point and grounded length at every output
    time over 1 s (the same discrete equations: 1e-6 m, the interpolation of the crossing
    amplifying Newton's tolerance by the slope of the penetration), and the summary's
    grounded-length range per line."""
    from cablefem.app.run import run_case

    out = {}
    for name, d in (("single", mooring_single()), ("net", mooring_network(mpi_tmp_path))):
        d["dynamics"] = {"t_end": 1.0, "dt": 0.05}
        res = run_case(parse_case(d), mpi_tmp_path / name, comm, figures=False,
                       progress=False, modes=0)
        rows = None
        if comm.rank == 0:
            import csv

            with open(mpi_tmp_path / name / "touchdown.csv", newline="") as fh:
                rows = list(csv.DictReader(fh))
        rows = comm.bcast(rows, root=0)
        out[name] = (np.array([[float(r[c]) for c in ("time", "x", "y", "z",
                                                          "grounded_length")] for r in rows]),
                     {r["line"] for r in rows}, res.summary["touchdown"])
    (a, la, sa), (b, lb, sb) = out["single"], out["net"]
    assert la == {"cable"} and lb == {"line"} and a.shape == b.shape == (21, 5)
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-6)
    assert sb["line"]["grounded_length_max"] == pytest.approx(
        sa["cable"]["grounded_length_max"], abs=1e-6)
