"""The XDMF output opens in ParaView's own reader (headless ``pvpython``): runs when
ParaView is installed (Debian's ``paraview``), skipped otherwise."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.serial,
              pytest.mark.skipif(shutil.which("pvpython") is None,
                                 reason="ParaView (pvpython) is not installed")]

SCRIPT = r'''
import json, sys
from paraview import simple
out = {}
for name in sys.argv[1:]:
    reader = simple.OpenDataFile(name)
    reader.UpdatePipelineInformation()
    times = list(reader.TimestepValues) if hasattr(reader, "TimestepValues") else []
    reader.UpdatePipeline(times[-1] if times else 0.0)
    info = reader.GetDataInformation()
    pd = reader.PointData.keys()
    cd = reader.CellData.keys()
    out[name] = {"points": info.GetNumberOfPoints(), "cells": info.GetNumberOfCells(),
                 "times": len(times), "point_arrays": sorted(pd), "cell_arrays": sorted(cd)}
print("JSON" + json.dumps(out))
'''


def test_xdmf_opens_in_paraview(tmp_path):
    """A short network run (the fan, 3 stays of 10 elements): ParaView reads string.xdmf
    with 33 points, 30 cells, every field and 5 time steps, and moments.xdmf with its
    arrays; the numbers come from the mesh and the output strides. (This test found that
    meshio's Polyline topology lacked NodesPerElement, which made ParaView abort.)"""
    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(Path(__file__).parent))
    from test_network import fan_case, fan_mesh  # noqa: E402

    from cablefem.case import parse_case
    from cablefem.run import run_case

    mesh = fan_mesh(str(tmp_path / "fan.msh"))
    d = fan_case(mesh, g=9.81, dynamics={"t_end": 0.2, "dt": 0.005, "fields_every": 10})
    out = tmp_path / "run"
    run_case(parse_case(d), out, figures=False, progress=False)
    script = tmp_path / "read.py"
    script.write_text(SCRIPT)
    res = subprocess.run(["pvpython", str(script), str(out / "string.xdmf"),
                          str(out / "moments.xdmf"), str(out / "string.pvd")],
                         capture_output=True, text=True, timeout=300, cwd=root)
    assert res.returncode == 0, res.stderr[-2000:]
    info = json.loads(res.stdout.split("JSON", 1)[1])
    s = info[str(out / "string.xdmf")]
    # dolfinx writes each function (displacement, velocity, tension, strain) as a grid of
    # its own: ParaView loads them as 4 blocks of the 33-node, 30-cell mesh
    assert (s["points"], s["cells"], s["times"]) == (4 * 33, 4 * 30, 5)
    assert {"displacement", "velocity"} <= set(s["point_arrays"])
    assert {"tension", "strain"} <= set(s["cell_arrays"])
    p = info[str(out / "string.pvd")]  # one dataset with every field
    assert (p["points"], p["cells"], p["times"]) == (33, 30, 5)
    assert {"displacement", "velocity"} <= set(p["point_arrays"])
    assert {"tension", "strain"} <= set(p["cell_arrays"])
    m = info[str(out / "moments.xdmf")]
    assert m["times"] == 5 and {"moment", "curvature", "displacement"} <= set(m["point_arrays"])
