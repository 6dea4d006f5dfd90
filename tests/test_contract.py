"""The models' declared contract (cablefem.contract.LineModel): every capability a solver
branches on is a declared attribute of the string, the network and the rod (no probing),
the three built models satisfy the Protocol, and the layout's modules import alone in a
fresh interpreter (no import cycle), the contract without dolfinx."""

from __future__ import annotations

import subprocess
import sys

import pytest
from mpi4py import MPI
from test_network import fan_case, fan_mesh

from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.contract import CAPABILITIES, Builders, LineModel
from cablefem.network import NetworkModel
from cablefem.rod import BeamModel

#: the string's declared values; a network and a rod set their own where they differ
OWN = {NetworkModel: {"is_network": True, "ramp_weight": True},
       BeamModel: {"bs": 6, "is_beam": True, "kink_offsets": False}}


@pytest.mark.parametrize("cls", [CableModel, NetworkModel, BeamModel])
def test_capabilities_are_declared(cls):
    """Each capability of CAPABILITIES is a class attribute (readable without a model, as
    the solvers read it), equal to the string's default unless the class sets its own;
    each class names what it is built from (Builders), its own."""
    assert isinstance(cls.builders, Builders)
    assert len({CableModel.builders, NetworkModel.builders, BeamModel.builders}) == 3
    for name, default in CAPABILITIES.items():
        assert hasattr(cls, name), name
        if name == "static_stages" and cls is BeamModel:
            assert callable(cls.static_stages)  # the rod's soft-shear pre-solves
        elif name == "static_options" and cls is BeamModel:
            assert cls.static_options["snes_linesearch_type"] == "basic"
        else:
            assert getattr(cls, name) == OWN.get(cls, {}).get(name, default), name


def _taut(**extra):
    return {"section": {"EA": 1.0e6, "EI": 1.0, "mass": 1.0},
            "geometry": {"length": 10.0}, "mesh": {"elements": 6},
            "anchors": [{"name": "p", "position": [0.0, 0, 0]},
                        {"name": "q", "position": [10.0, 0, 0]}], **extra}


def test_models_satisfy_the_protocol(mpi_tmp_path):
    """A string, a rod and a network, built, are LineModel instances (every member the
    solvers read is there), and their line discretisation gathers what it scatters."""
    import numpy as np

    models = [CableModel(MPI.COMM_WORLD, parse_case(_taut())),
              BeamModel(MPI.COMM_WORLD, parse_case(_taut(beam={"span_elements": 6}))),
              NetworkModel(MPI.COMM_WORLD, parse_case(fan_case(
                  fan_mesh(str(mpi_tmp_path / "fan.msh")))))]
    for model in models:
        assert isinstance(model, LineModel), type(model).__name__
        n = len(model.geometry.stations)
        values = np.arange(n * model.bs, dtype=float).reshape(n, model.bs)
        model.scatter_nodal(values, model.u)
        back = model.gather_all(model.u)
        if model.comm.rank == 0:  # exact: a copy of the same numbers
            np.testing.assert_array_equal(back, values)


MODULES = ["cablefem.contract", "cablefem.line", "cablefem.plausibility",
           "cablefem.cable_geometry", "cablefem.string_terms", "cablefem.hinge_law",
           "cablefem.hinge", "cablefem.cable", "cablefem.network", "cablefem.rod_kinematics",
           "cablefem.rod",
           "cablefem.statics", "cablefem.dynamics"]


@pytest.mark.serial
def test_modules_import_alone_and_statics_imports_no_model():
    """Each module of the model's layout imports first in a fresh interpreter (an import
    cycle fails there); statics does not import the rod, and the contract loads no
    dolfinx."""
    for mod in MODULES:
        subprocess.run([sys.executable, "-c", f"import {mod}"], check=True)
    code = ("import sys, cablefem.statics, cablefem.contract; "
            "print('cablefem.rod' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True).stdout.split()
    assert out == ["False"]
    code = "import sys, cablefem.contract; print('dolfinx' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True).stdout.split()
    assert out == ["False"]
