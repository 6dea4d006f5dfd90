"""A term of a model's residual, with everything the solvers need to know about it
(``docs/extending.md``).

A :class:`Term` is a UFL form (linear in the model's test function, with the sign it has in
the residual) and its kind, plus its life beside the form: how it follows time, how it
linearises for the modal analysis, whether it moves the mass matrix and whether it is a
force of the medium (water, seabed) that the two sides of a kink share. Every term, the
model's physics (fluid, seabed, dampers, span bending) and a user's alike, enters through
one door, :meth:`cablefem.forms.CableForms.add`; the solvers ask
:class:`~cablefem.forms.CableForms` (``set_time``, ``linearised``, ``mass_moves``,
``medium_forms``), never a physics module, and never look a term up by its name.

Pure UFL: no meshes, no solvers.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import ufl
from ufl.algorithms import estimate_total_polynomial_degree, expand_derivatives
from ufl.algorithms.check_arities import ArityMismatch, check_form_arity

__all__ = ["Term", "KINDS", "checked", "depends_on", "mass_part"]

#: kinds of a term: where it acts (``static``: statics and dynamics; ``dynamic``: dynamics)
KINDS = ("static", "dynamic")


@dataclass(eq=False)
class Term:
    """One term of the residual and its life.

    Args:
        name: its label (unique in the model's forms; ``forms.remove(name)`` takes it out).
        form: a UFL form linear in the model's test function ``model.du`` (no other
            argument), with the sign it has in the residual: a force ``f`` as ``−f·δu``.
        kind: ``"static"``, a force of the configuration acting in statics and dynamics (it
            may depend on ``u`` only), or ``"dynamic"``, acting in dynamics only (it may
            depend on ``u``, ``v`` and, linearly, ``a``).
        set_time: its time law, ``set_time(t)``, called whenever the model's time is set
            (in statics ``t = 0``, in dynamics at every residual evaluation and output);
            it updates the term's own coefficients (``fem.Constant``, ``fem.Function``). A
            term may instead use the UFL time Constant ``model.forms.time`` in its form.
        linearised: a factory of a context manager (``linearised()``) within which the
            term is at the state the modal analysis linearises about (e.g. the fluid's
            steady current, the seabed without its regularised friction); None: the term
            as it stands, at rest (``v = a = 0``).
        moves_mass: whether the term's mass ``∂form/∂a`` changes with the state or with
            time, so that the anchor reactions assemble the mass matrix again at every
            evaluation. None (default): derived when the term is added, True when the
            term depends on ``a`` and its mass part depends on ``u`` or ``v`` or the time
            Constant, or the term has a time law (``set_time``). Say True for a mass that
            changes otherwise (a Function you update yourself).
        medium: True for a force of the surrounding medium (drag, buoyancy, added mass,
            seabed contact): at a kink its cell integrals are the force the two sides
            share (:mod:`cablefem.kinks`).
        slow_jacobian: True when the term's Jacobian changes slowly with the state and
            costs much (a fluid's drag and added mass): a time integrator that keeps its
            Jacobian over steps keeps this part longest and refreshes the others' part
            alone where that serves (:mod:`cablefem.stepnewton`). Only the cost of Newton's
            iterations depends on it, never the answer beyond Newton's tolerance.
    """

    name: str
    form: ufl.Form
    kind: str = "static"
    set_time: Callable[[float], None] | None = None
    linearised: Callable[[], contextlib.AbstractContextManager] | None = None
    moves_mass: bool | None = None
    medium: bool = False
    slow_jacobian: bool = False


def depends_on(form, w, trial) -> bool:
    """True when ``form`` varies with the coefficient ``w`` (its Gateaux derivative is not
    identically zero; a form without ``w`` does not: no derivative taken)."""
    if w not in form.coefficients():
        return False
    return not expand_derivatives(ufl.derivative(form, w, trial)).empty()


def mass_part(form, a, trial=None):
    """``∂form/∂a`` with the derivatives expanded (a form with one more argument), or None
    when the form does not depend on the acceleration ``a``."""
    if a not in form.coefficients():
        return None
    part = expand_derivatives(ufl.derivative(form, a, trial))
    return None if part.empty() else part


def checked(term: Term, test, u, v, a, dx, time=None) -> Term:
    """``term`` checked for :meth:`CableForms.add` (ValueError naming it when it is not a
    residual term of its kind) and returned as stored: its form with the derivatives
    expanded (a term given as a Gateaux derivative in the direction ``v``, ``β dF/du
    [v]``, must show ``v`` for the Jacobian's derivative in ``v``) and ``moves_mass``
    derived when None (``time``: the forms' time Constant, if any)."""
    name, form, kind = term.name, term.form, term.kind
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    if not isinstance(form, ufl.Form) or form.empty():
        raise ValueError(f"term {name!r}: expected a UFL form (an integral ... * dx), "
                         f"got {type(form).__name__}")
    if form.arguments() != (test,):
        raise ValueError(f"term {name!r}: the form must be linear in the model's test "
                         f"function (model.du) and have no other argument; its arguments "
                         f"are {form.arguments()}")
    _check_rule(name, form, dx)
    form = expand_derivatives(form)
    _check_linear(name, form, a)
    if kind == "static":
        rates = [w.name for w in (v, a) if w in form.coefficients()]
        if rates:
            raise ValueError(f"term {name!r} depends on {', '.join(rates)}: statics has "
                             "no velocity or acceleration; add it with kind='dynamic'")
    moves = term.moves_mass
    if moves is None:
        mass = mass_part(form, a)
        moves = mass is not None and (
            term.set_time is not None or u in mass.coefficients()
            or v in mass.coefficients() or (time is not None and time in mass.constants()))
    return dataclasses.replace(term, form=form, moves_mass=bool(moves))


def _check_linear(name: str, form, a) -> None:
    """A residual term is linear in the test function (``inner(du, du)*dx`` is not; its
    Jacobian failed in ``compile`` with "too many values to unpack") and, in dynamics, in
    the acceleration (the integrator's mass matrix is its derivative in ``a``)."""
    try:
        check_form_arity(form, form.arguments())
    except (ArityMismatch, ValueError):  # UFL 2022's message itself fails to format
        raise ValueError(f"term {name!r}: the form is not linear in the test function "
                         "model.du (a product of du with itself, or du inside a "
                         "nonlinear function): a residual term is f . du, f free of "
                         "du") from None
    if a in form.coefficients():
        second = expand_derivatives(ufl.derivative(ufl.derivative(form, a), a))
        if not second.empty():
            raise ValueError(f"term {name!r}: the form is not linear in the acceleration "
                             "model.a (the time integrator's mass matrix is the "
                             "derivative in a, a constant): an added mass is m_a a . du")


def _check_rule(name: str, form, dx) -> None:
    """A model that integrates its cells with one point (the rod: ``dx`` with quadrature
    degree 0) takes cell integrals of one point only: FFCx 0.5 fails to compile a Jacobian
    whose cell integrals mix that rule with one of more points (it declares the cell
    Jacobian twice)."""
    fixed = dx.metadata().get("quadrature_degree")
    if fixed is None:
        return
    for itg in form.integrals_by_type("cell"):
        degree = itg.metadata().get("quadrature_degree")
        if degree is None:
            degree = estimate_total_polynomial_degree(expand_derivatives(itg.integrand()))
        if degree > 1:  # one Gauss point integrates degree 1 exactly
            raise ValueError(
                f"term {name!r}: this model integrates every cell term with one point; "
                f"integrate with model.forms.dx (a product of two P1 fields exactly: "
                f"cablefem.rod.p1_product), not a rule of degree {degree}")
