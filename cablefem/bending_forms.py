"""UFL forms of the bending the string carries outside UFL's cell integrals: the span's
bending lumped at interior vertices, and the moment a clamp's boundary layer hands to the
span at its end (``docs/theory.md`` §6.1). Kinematics and conventions as in
:mod:`cablefem.forms`."""

from __future__ import annotations

import ufl

from cablefem.forms import ds_, stretch_vector

__all__ = ["turning_cosine", "span_bending_energy", "span_bending_form", "span_bending_work",
           "end_moment_density", "end_moment_work"]


def turning_cosine(u, t0):
    """Cosine of the angle between the deformed tangents of the two elements meeting at an
    interior vertex, ``cos θ = σ e+ · e−`` with ``e = ∂s r / λ`` on each side (restricted
    to ``("+")``/``("-")``: for a ``dS`` integral). ``σ = sign(t0+ · t0−)`` makes it
    independent of how each cell of the mesh is oriented (``t0`` and ``e`` flip together)."""
    g = stretch_vector(u, t0)
    gp, gm = g("+"), g("-")
    sigma = ufl.sign(ufl.dot(t0("+"), t0("-")))
    return sigma * ufl.dot(gp, gm) / ufl.sqrt(ufl.dot(gp, gp) * ufl.dot(gm, gm))


def span_bending_energy(u, t0, EI, mesh, c=1.0):
    """Bending energy of the span at an interior vertex (integrate with ``dS``):
    ``EI (1 − cos θ) / h̄`` with ``θ`` the turning angle between the neighbouring elements'
    deformed tangents and ``h̄`` the mean stress-free length of the two elements (``EI``
    a number or a cell field: then the mean of the two elements'), ``c``
    (a cell field or a number) times the mesh length (``docs/theory.md`` §6.1; the model
    passes the outer string's, c = 1, also in a hinge's region). It is ``EI θ² / (2 h̄)``
    to ``O(θ⁴)``: the energy ``∫ EI κ² / 2 ds`` of a curvature ``κ = θ / h̄`` lumped at the
    vertex."""
    J = ufl.Jacobian(mesh)
    h = ufl.sqrt(ufl.dot(J[:, 0], J[:, 0]))  # mesh length of the cell (reference cell [0, 1])
    def side(f, s):  # a cell field takes the side's value; a constant is the same on both
        return f(s) if isinstance(f, ufl.Coefficient) else f

    hp, hm = h("+") * side(c, "+"), h("-") * side(c, "-")
    EIm = 0.5 * (side(EI, "+") + side(EI, "-"))  # a network's cell field: the sides' mean
    return EIm * (1.0 - turning_cosine(u, t0)) / (0.5 * (hp + hm))


def span_bending_form(u, t0, EI, mesh, dS=ufl.dS, c=1.0, skip=()):
    """:func:`span_bending_energy` summed over the interior vertices of ``dS``, less those
    tagged ``skip`` in it (a kink's vertex, whose turn belongs to its own layer)."""
    energy = span_bending_energy(u, t0, EI, mesh, c)
    form = energy * dS
    for tag in skip:
        form = form - energy * dS(tag)
    return form


def span_bending_work(u, du, t0, EI, mesh, dS=ufl.dS, c=1.0, skip=()):
    """Virtual work of the span's bending: the Gateaux derivative of
    :func:`span_bending_form` (its tangent is symmetric)."""
    return ufl.derivative(span_bending_form(u, t0, EI, mesh, dS, c, skip), u, du)


def end_moment_density(u, du, t0, EI, T, q, direction):
    """The integrand of :func:`end_moment_work` (no measure): to be restricted to a side of
    an interior vertex (a kink, ``docs/theory.md`` §6.1) or integrated over an end vertex."""
    g = stretch_vector(u, t0)
    lam = ufl.sqrt(ufl.dot(g, g))
    e = g / lam
    sgn = ufl.sign(ufl.dot(t0, direction))
    q_perp = q - ufl.dot(q, e) * e
    coeff = ufl.conditional(ufl.gt(T, 0.0), EI / T, 0.0)
    return sgn * coeff * ufl.dot(q_perp, ds_(du, t0)) / lam


def end_moment_work(u, du, t0, EI, T, q, direction, ds):
    """The residual term of the moment ``EI κ_s`` that a clamp's boundary layer hands to the
    span at its end (``docs/theory.md`` §6.1), on the first element (``ds``: its anchor
    vertex). ``κ_s = e × q / T`` is the string's own curvature at the anchor
    (:func:`cablefem.asymptotics.string_curvature`, ``q = m a − f`` per stress-free length,
    ``e`` the tangent into the span, ``T`` the first element's tension); its virtual work on
    the element's rotation ``e × δe`` is ``(EI/T) q⊥ · δe``. ``direction`` (the clamp's,
    into the span) orients the element. A slack element (``T = 0``) gets none."""
    return end_moment_density(u, du, t0, EI, T, q, direction) * ds
