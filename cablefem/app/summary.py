"""``summary.json`` of a run, assembled from its stages' results (:mod:`cablefem.app.stages`,
:mod:`cablefem.app.integration`, :mod:`cablefem.app.reports`): at the end, and part way
(status "running") so that a folder found after a kill says how far the run got. The keys'
order is that of the stages; the warnings are the stages' in their order."""

from __future__ import annotations

from dataclasses import dataclass

from cablefem import __version__
from cablefem.app.integration import Dynamics, Resonance, Resume
from cablefem.app.reports import Fatigue, Reports
from cablefem.app.stages import Built, Modes, Statics

__all__ = ["StageResults", "assemble"]


@dataclass
class StageResults:
    """The results of a run's stages so far (None: not reached)."""

    build: Built
    statics: Statics | None = None
    modes: Modes | None = None
    checkpoint: dict | None = None  #: the last checkpoint's time and step
    resume: Resume | None = None
    resonance: Resonance | None = None
    dynamics: Dynamics | None = None
    reports: Reports | None = None
    figures: dict | None = None
    fatigue: Fatigue | None = None
    wall_total: float | None = None

    def warnings(self) -> list[dict]:
        out = []
        for stage in (self.build, self.statics, self.modes, self.reports, self.fatigue):
            if stage is not None:
                out += stage.warnings
        return out


def assemble(r: StageResults) -> dict:
    """The summary of the stages ``r`` reached."""
    b = r.build
    s: dict = {"cablefem": __version__, "status": "running", "case": b.case.to_dict(),
               "mpi_ranks": b.model.comm.size, "length": b.model.length, "model": b.asked,
               "elements": b.elements, "degrees_of_freedom": b.dofs,
               "dimensionless": b.groups, "wall_time": {"build": b.wall_time},
               "warnings": r.warnings()}
    if b.launched is not None:
        s["mpi_ranks_launched"] = b.launched
    for key, value in (("bending", b.bending), ("beam", b.beam), ("notes", b.notes)):
        if value:
            s[key] = value
    if r.statics is None:
        return s
    st = r.statics
    s["static"] = st.entries
    s["wall_time"]["statics"] = st.result.wall_time
    s["outer_correction"] = st.outer_correction
    if st.span_bending is not None:
        s["span_bending"] = st.span_bending
        if b.auto is not None:
            s["span_bending_auto"] = b.auto
    s["checkpoint"] = r.checkpoint
    if r.modes is not None and r.modes.entries is not None:
        s["modes"] = r.modes.entries
        s["wall_time"]["modal"] = r.modes.wall_time
    if r.resume is not None:
        s["restarted_from"] = r.resume.time
    if r.resonance is not None:
        s.update(r.resonance.entries)
    if r.dynamics is not None:
        _dynamics(s, r.dynamics)
    if r.reports is not None:
        _reports(s, r.reports)
        if s["status"] == "running":
            s["status"] = "completed"
    if r.figures is not None:
        s["figures"] = r.figures
    if r.fatigue is not None and r.fatigue.entries is not None:
        s["fatigue"] = r.fatigue.entries
        if r.fatigue.error is not None:
            s["status"] = "failed"
            s["error"] = str(r.fatigue.error)
    if r.wall_total is not None:
        s["wall_time"]["total"] = r.wall_total
    return s


def _dynamics(s: dict, d: Dynamics) -> None:
    if d.entries is not None:
        s["dynamics"] = d.entries
        s["wall_time"]["dynamics"] = d.wall_time
    if d.status is None:
        return
    s["status"] = d.status
    if d.status == "interrupted":
        s["signal"] = d.signal
    s["error"] = d.message
    if d.failure_state_time is not None:
        s["failure_state_time"] = d.failure_state_time


def _reports(s: dict, rep: Reports) -> None:
    s["anchors"] = rep.anchors
    if rep.statistics_start is not None:
        s["statistics_start"] = rep.statistics_start
    if rep.touchdown is not None:
        s["touchdown"] = rep.touchdown
    if rep.kinks is not None:
        s["kinks"] = rep.kinks
    if rep.dampers is not None:
        s["dampers"] = rep.dampers
