"""Modal analysis about the static state with SLEPc.

Generalised eigenproblem ``K0 φ = ω² M φ`` with ``K0`` the tangent stiffness at
static equilibrium (elastic plus geometric stiffness) and ``M`` the consistent mass (plus
point masses). Anchor rows: ``K0`` has 1 on the diagonal and ``M`` 0, which sends the
constrained directions to infinite eigenvalues; shift-and-invert about 0 returns the lowest
finite ones. PETSc/SLEPc options prefix ``<model prefix>modal_``.

With virtual hinges (the first-order correction at clamps, ``hinge.py``) the stiffness is
that of the layers' law the dynamics solves, set from the static state
(:meth:`~cablefem.hinge.VirtualHinges.start_dynamics`), not the statics' elastic law: its
tangent depends on the anchor angle and is not symmetric (about 1e-3 of ``‖K0‖``), so the
problem is a generalised non-Hermitian one; its eigenvalues are real to round-off (a
complex pair would be flagged), and symmetrising ``K0`` instead would move the in-plane
frequencies by percents.

Every mode is classified: *in-plane* or *out-of-plane* (the plane of the chord and gravity,
by the share of the mode's nodal amplitude normal to it) and, for a level cable with a
mirror-symmetric mesh, *symmetric* or *antisymmetric* about mid-span (by the correlation of
the mode with its mirror image).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from slepc4py import SLEPc

from cablefem import junctions
from cablefem.petsc_utils import case_options, default_options, lu_options, model_dofs
from cablefem.units import unit

__all__ = ["ModalProblem", "ModalResult", "solve_modes", "classify_mode", "free_dofs"]

log = logging.getLogger(__name__)

#: smallest modal assurance criterion (mass-weighted correlation) with which an undamped
#: mode takes a complex mode's damping ratio
MIN_MAC = 0.1
#: largest share of a mode's squared amplitude on the other side of the plane of the chord
#: and gravity for the label 'in-plane' or 'out-of-plane'; between, the mode is 'mixed'
#: (without a current or wind that plane is a symmetry plane: shares 0 or 1 to round-off)
MIXED_SHARE = 0.1
#: relative distance of |lambda| from a mode's frequency within which a mode that no complex
#: mode resembles takes the nearest one left
NEAR_OMEGA = 0.05


@dataclass
class ModalResult:
    omegas: np.ndarray  #: natural circular frequencies, rad/s (ascending)
    shapes: list[fem.Function]  #: mode shapes (max nodal amplitude 1)
    labels: list[dict]  #: classification of each mode
    wall_time: float
    #: damping ratio of each mode from the damped system's complex modes (0 without
    #: damping; NaN for a mode with no complex partner)
    damping_ratios: np.ndarray | None = None
    #: |lambda| of each mode's complex eigenvalue (None without damping)
    damped_omegas: np.ndarray | None = None


def classify_mode(stations: np.ndarray, shape: np.ndarray, chord: np.ndarray,
                  gravity_dir: np.ndarray | None, mirror: bool) -> dict:
    """Classify a nodal mode shape (n_nodes, 3) of a single cable, in station order.

    ``plane``: 'in-plane' or 'out-of-plane', the side of the plane of the chord and gravity
    holding all but :data:`MIXED_SHARE` of the shape's squared amplitude, 'mixed' when
    neither does (a cable blown out of that plane by a current or wind, or two modes of
    nearly equal frequency that the eigensolver returns as combinations; the share says
    how much); absent without gravity or with a chord along gravity. ``symmetry``: the
    correlation of the shape with its mirror image about
    the plane normal to the chord at mid-span, when the stations are mirror-symmetric:
    'symmetric' above 0.5, 'antisymmetric' below -0.5, else 'mixed'. A level cable's modes
    are exactly one or the other; an inclined cable's are so to O(sag x inclination), and
    the correlation is reported beside the label. Returns also ``out_of_plane_share`` and
    ``symmetry_correlation`` where they are defined (absent, never "n/a", otherwise).
    """
    e_c = chord / np.linalg.norm(chord)
    out: dict = {}
    norm2 = float(np.sum(shape * shape))
    if gravity_dir is not None:
        n = np.cross(e_c, gravity_dir)
        if np.linalg.norm(n) > 1e-8:
            n /= np.linalg.norm(n)
            share = float(np.sum((shape @ n) ** 2) / norm2)
            out["out_of_plane_share"] = share
            out["plane"] = ("out-of-plane" if share >= 1 - MIXED_SHARE else "in-plane"
                            if share <= MIXED_SHARE else "mixed")
    if mirror:
        L = stations[-1]
        mirrored = np.column_stack([np.interp(L - stations, stations, shape[:, k])
                                    for k in range(3)])
        P = np.eye(3) - 2.0 * np.outer(e_c, e_c)
        corr = float(np.sum(shape * (mirrored @ P.T)) / norm2)
        out["symmetry_correlation"] = corr
        out["symmetry"] = ("symmetric" if corr > 0.5 else "antisymmetric" if corr < -0.5
                           else "mixed")
    return out


def classify_network_mode(points: np.ndarray, shape: np.ndarray) -> dict:
    """Classify a nodal mode shape (n_nodes, 3) of a network against the plane that fits
    its nodes best (least squares): ``plane`` 'normal' when most of the squared amplitude is
    normal to that plane, else 'in-plane', with ``normal_share``; nothing when the nodes
    are on a line (no plane)."""
    X = points - points.mean(axis=0)
    _, sv, vt = np.linalg.svd(X, full_matrices=False)
    if sv.size < 2 or sv[1] < 1e-9 * sv[0]:
        return {}
    n = vt[-1]
    share = float(np.sum((shape @ n) ** 2) / np.sum(shape * shape))
    return {"plane": "normal" if share > 0.5 else "in-plane", "normal_share": share}


def _label_text(lab: dict) -> str:
    parts = [lab[k] for k in ("plane", "symmetry") if k in lab]
    if lab.get("plane") == "mixed":
        parts[0] = f"mixed (out-of-plane share {lab['out_of_plane_share']:.2f})"
    return (" " + " ".join(parts)) if parts else ""


def free_dofs(model) -> int:
    """Number of degrees of freedom not fixed by the model's Dirichlet conditions (global,
    collective): how many natural modes there are at most."""
    x = fpetsc.create_vector(model.f_static)
    x.set(1.0)
    fpetsc.set_bc(x, model.bcs, scale=0.0)  # the fixed entries become 0 * g = 0
    n = x.sum()
    x.destroy()
    return int(round(n))


class ModalProblem:
    """The ``n`` lowest natural modes about the model's current state ``model.u``
    (normally the static equilibrium) as an object that owns its SLEPc eigensolver.

    Assembles ``K0`` and ``M`` and creates the EPS (``.eps``: generalised Hermitian, or
    non-Hermitian with hinges; shift and invert about 0) under the options prefix
    ``petsc_options_prefix`` (default ``<model prefix>modal_``: ``-cable_modal_eps_tol``,
    ``-cable_modal_st_type``,
    ``-cable_modal_st_pc_type``, ...); option priority as :class:`cablefem.statics.
    StaticProblem`'s (defaults < case file's ``modal_`` keys < ``petsc_options`` < options
    database). :meth:`solve` solves and classifies; :meth:`destroy` (or the end of a
    ``with`` block) frees the EPS and the matrices::

        with ModalProblem(model, 6) as problem:
            omegas = problem.solve().omegas
    """

    def __init__(self, model, n: int = 6, *, petsc_options_prefix: str | None = None,
                 petsc_options: dict | None = None):
        self.model = model
        self.n = n
        self.prefix = (model.prefix + "modal_" if petsc_options_prefix is None
                       else petsc_options_prefix)
        hinges = model.hinges
        if hinges:  # linearise what the dynamics solves: the layers' law (module docs)
            hinges.start_dynamics(model.u.x.array)
        forms = model.forms
        dynamic_terms = any(kind == "dynamic" for _, kind in forms.user.values())
        # the motion about a state at rest: v = a = 0 while assembling
        saved = [f.x.array.copy() for f in (model.v, model.a)]
        for f in (model.v, model.a):
            f.x.array[:] = 0.0
        # every term at its linearisation state (the fluid's steady current, no waves or
        # gusts; the seabed without its friction; a user's term's own)
        with forms.linearised():
            try:
                # K: the static tangent, plus the dynamic terms' stiffness (dampers' springs)
                k_form = forms.k_dynamic if dynamic_terms else model.j_static
                self.K = junctions.create_matrix(model, k_form)
                fpetsc.assemble_matrix(self.K, k_form, model.bcs, diagonal=1.0)
                junctions.add_jacobian(model, self.K, junctions.fixed_dofs(model))
                self.K.assemble()
                self.M = fpetsc.assemble_matrix(model.m_form, model.bcs, diagonal=0.0)
                self.M.assemble()
                self.C = None  # the damping matrix, when the dynamic residual has one
                if forms.c_form is not None:
                    self.C = fpetsc.assemble_matrix(forms.c_form, model.bcs, diagonal=0.0)
                    self.C.assemble()
            finally:
                for f, x in zip((model.v, model.a), saved):
                    f.x.array[:] = x
        defaults = {"st_type": "sinvert", "eps_target": 0.0, "eps_tol": 1e-12,
                    **{"st_" + k: v
                       for k, v in lu_options(model.comm.size, model_dofs(model)).items()}}
        eps = SLEPc.EPS().create(model.comm)
        eps.setOptionsPrefix(self.prefix)
        eps.setOperators(self.K, self.M)
        eps.setProblemType(SLEPc.EPS.ProblemType.GNHEP if hinges or dynamic_terms else
                           SLEPc.EPS.ProblemType.GHEP)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        eps.setDimensions(n, max(2 * n + 1, n + 15))
        user = {**case_options(model, "modal"), **(petsc_options or {})}
        with default_options(self.prefix, defaults, user):
            eps.setFromOptions()
        self.eps = eps

    def solve(self) -> ModalResult:
        """Solve, sort by frequency, normalise (max nodal amplitude 1) and classify."""
        model, n, eps, K = self.model, self.n, self.eps, self.K
        t0 = time.perf_counter()
        eps.solve()
        nconv = eps.getConverged()
        if nconv < n:
            raise RuntimeError(f"modal analysis: only {nconv} of {n} eigenpairs converged")
        vals, shapes = [], []
        vr = K.createVecRight()
        for i in range(nconv):
            lam = eps.getEigenpair(i, vr)
            if abs(lam.imag) > 1e-8 * abs(lam):
                log.warning("modal: eigenvalue %d is complex (%.6g%+.6gj): the stiffness "
                            "is not that of a conservative system", i + 1, lam.real,
                            lam.imag)
            lam = lam.real
            f = fem.Function(model.V, name=f"mode_{i + 1}")
            vr.copy(f.vector)
            f.x.scatter_forward()
            vals.append(lam)
            shapes.append(f)
        vr.destroy()
        res = self._result(vals, shapes, t0)
        res.damping_ratios = np.zeros(len(res.omegas))
        if self.C is not None:
            res.damping_ratios, res.damped_omegas = self._damped(res)
        return res

    def _damped(self, res: ModalResult) -> tuple[np.ndarray, np.ndarray]:
        """Damping ratio and ``|λ|`` of each mode of ``res`` from the quadratic eigenproblem
        ``(λ² M + λ C + K) φ = 0`` (SLEPc PEP, shift and invert about 0, options prefix
        ``<prefix>pep_``): each undamped mode takes the complex mode (``Im λ > 0``) whose
        shape is closest to it in the mass norm (MAC), or else the one left whose ``|λ|``
        is within 5 % of its frequency; ``ζ = −Re λ/|λ|``. A mode with no complex partner
        (overdamped) gets NaN and a warning. ``K`` and ``C`` are about the cable at rest in
        the steady current, without the seabed's regularised friction
        (:func:`cablefem.seabed.without_friction`): every term linearised
        (:meth:`cablefem.forms.CableForms.linearised`)."""
        model, n = self.model, len(res.omegas)
        pep = SLEPc.PEP().create(model.comm)
        pep.setOptionsPrefix(self.prefix + "pep_")
        pep.setOperators([self.K, self.C, self.M])
        pep.setProblemType(SLEPc.PEP.ProblemType.GENERAL)
        nev = 2 * n + 4  # conjugate pairs, and room for real (overdamped) roots
        pep.setDimensions(nev, max(2 * nev, nev + 30))
        pep.setTarget(0.0)
        pep.setWhichEigenpairs(SLEPc.PEP.Which.TARGET_MAGNITUDE)
        defaults = {"st_type": "sinvert", "pep_tol": 1e-12,
                    **{"st_" + k: v
                       for k, v in lu_options(model.comm.size, model_dofs(model)).items()}}
        with default_options(self.prefix + "pep_", defaults, {}):
            pep.setFromOptions()
        pep.solve()
        vr, vi = self.K.createVecRight(), self.K.createVecRight()
        Mv = self.K.createVecRight()
        cands = []
        for i in range(pep.getConverged()):
            lam = complex(pep.getEigenpair(i, vr, vi))
            if lam.imag <= 1e-10 * abs(lam):
                continue  # the conjugate, or a real (overdamped) root
            shape = []
            for x in (vr, vi):
                self.M.mult(x, Mv)
                shape.append((Mv.copy(), x.dot(Mv)))
            cands.append((lam, shape))
        zeta, wabs = np.full(n, np.nan), np.full(n, np.nan)
        # MAC of every (mode, complex mode) pair; the pairs taken greedily from the most
        # alike: a degenerate pair of undamped modes (two planes) comes out of the EPS as
        # any two combinations of the damped system's two modes, which this still pairs
        mac = np.zeros((n, len(cands)))
        for k, phi in enumerate(res.shapes):
            pMp = phi.vector.dot(self._mass_action(phi.vector, Mv))
            for j, (_, shape) in enumerate(cands):
                den = pMp * sum(xMx for _, xMx in shape)
                mac[k, j] = (sum(phi.vector.dot(Mx) ** 2 for Mx, _ in shape) / den
                             if den > 0 else 0.0)
        free = set(range(len(cands)))
        while mac.size and mac.max() > MIN_MAC:
            k, j = np.unravel_index(np.argmax(mac), mac.shape)
            lam = cands[j][0]
            zeta[k], wabs[k] = -lam.real / abs(lam), abs(lam)
            mac[k, :] = 0.0
            mac[:, j] = 0.0
            free.discard(j)
        # a multiple eigenvalue may come with eigenvectors that repeat one direction of
        # its space (seen on 2 ranks): the mode left takes the nearest free |lambda|
        for k in np.nonzero(np.isnan(zeta))[0]:
            near = sorted(free, key=lambda j: abs(abs(cands[j][0]) - res.omegas[k]))
            if near and abs(abs(cands[near[0]][0]) / res.omegas[k] - 1) < NEAR_OMEGA:
                lam = cands[near[0]][0]
                zeta[k], wabs[k] = -lam.real / abs(lam), abs(lam)
                free.discard(near[0])
        for k in np.nonzero(np.isnan(zeta))[0]:
            log.warning("modal: mode %d has no complex mode of the damped system like it "
                        "(overdamped?): no damping ratio", k + 1)
        for obj in [vr, vi, Mv, pep] + [Mx for _, shape in cands for Mx, _ in shape]:
            obj.destroy()
        for k in np.nonzero(np.isfinite(zeta))[0]:
            log.info("mode %d: damping ratio %.6g (|lambda| = %.6g)", k + 1, zeta[k], wabs[k])
        return zeta, wabs

    def _mass_action(self, x, out):
        self.M.mult(x, out)
        return out

    def _result(self, vals: list, shapes: list, t0: float) -> ModalResult:
        model, n = self.model, self.n
        order = np.argsort(vals)[:n]
        omegas = np.sqrt(np.maximum(np.array(vals)[order], 0.0))
        if np.any(np.array(vals)[order] < 0):
            log.warning("modal: negative eigenvalue(s): the static state is not stable")
        shapes = [shapes[i] for i in order]
        if len(model.anchors) == 2 and not model.is_network:
            a0, a1 = model.anchors
            chord = a1.position - a0.position
            g = model.case.gravity
            gdir = np.asarray(g.direction, float) if g.g > 0 else None
            st = model.geometry.stations
            # mirror symmetry about mid-span needs mirror-symmetric stations
            mirror = bool(np.allclose(st, st[-1] - st[::-1], atol=1e-12 * st[-1]))
            classify = True
        else:  # a network: against the plane that fits its nodes
            classify = False
        labels = []
        for i, f in enumerate(shapes):
            nodal = model.gather_nodal(f)
            lab = None
            if model.comm.rank == 0:
                amax = np.max(np.abs(nodal))
                lab = (classify_mode(st, nodal / amax, chord, gdir, mirror) if classify
                       else classify_network_mode(model.geometry.points, nodal / amax))
                sign = np.sign(nodal.flat[np.argmax(np.abs(nodal))])
                lab["scale"] = float(sign / amax)
            lab = model.comm.bcast(lab, root=0)
            f.x.array[:] *= lab.pop("scale")
            f.name = f"mode_{i + 1}"
            labels.append(lab)
        res = ModalResult(omegas, shapes, labels, time.perf_counter() - t0)
        for i, (w, lab) in enumerate(zip(omegas, labels)):
            log.info("mode %d: omega = %.6g %s (f = %.6g %s)%s", i + 1, w,
                     unit(model.case.units, "omega"), w / 2 / np.pi,
                     unit(model.case.units, "frequency"), _label_text(lab))
        return res

    def destroy(self) -> None:
        """Free the EPS and the matrices."""
        for obj in (self.eps, self.K, self.M, self.C):
            if obj is not None:
                obj.destroy()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()


def solve_modes(model, n: int = 6) -> ModalResult:
    """The ``n`` lowest natural frequencies and modes about the current state ``model.u``
    (call :func:`cablefem.statics.solve_static` first): a :class:`ModalProblem` made,
    solved and destroyed."""
    t0 = time.perf_counter()
    with ModalProblem(model, n) as problem:
        res = problem.solve()
    res.wall_time = time.perf_counter() - t0  # the assembly included, as it always was
    return res
