"""UFL forms of the 3D extensible string (``docs/theory.md`` §2).

Nothing else lives here: no meshes, no solvers. Every function takes UFL objects and returns
UFL expressions or forms. :class:`CableForms` holds a model's residual as terms
(:class:`cablefem.terms.Term`: the model's own and a user's: drag, buoyancy, a dashpot, ...)
and derives every residual, Jacobian and mass form the solvers use from them
(``model.forms``, ``docs/extending.md``).

Kinematics on a 1D mesh embedded in 3D, with ``s`` the arc length of the mesh (the
reference configuration). A single cable's mesh is its stress-free geometry; a network's
mesh is its pretensioned geometry, each cell of stress-free length ``c`` times its mesh
length (``c = 1/(1 + T0/EA)`` for a pretension ``T0``); every function below takes ``c``
(default 1), strains are measured against the stress-free length and masses and
distributed loads are per stress-free length (so they carry a factor ``c`` per mesh length).
With ``c = 1``:

* reference tangent ``t0 = J[:, 0] / |J[:, 0]|`` (``J`` the cell Jacobian),
* ``∂s u = grad(u) t0``, ``∂s r = t0 + ∂s u``, stretch ``λ = |∂s r|``, strain ``v3 = λ − 1``,
* tension ``T = EA v3`` (``EA max(v3, 0)`` for a tension-only cable, the default),
* internal force ``N = T ∂s r / λ``.

Weak form (paper Eq. 16 in weak form), for all admissible ``δu``::

    ∫ m ü·δu ds + ∫ N·∂s δu ds + damping − ∫ f·δu ds − Σ P_i·δu(s_i) = 0
"""

from __future__ import annotations

import contextlib

import ufl

from cablefem.terms import KINDS, Term, checked, depends_on

__all__ = ["CableForms", "reference_tangent", "ds_", "stretch_vector", "stretch", "axial_strain",
           "tension", "layer_law_tension", "layer_stretch_vector",
           "internal_force", "internal_work", "inertia_work", "load_work",
           "strain_rate", "axial_damping_work", "strain_energy_density"]


def reference_tangent(mesh) -> ufl.core.expr.Expr:
    """Unit tangent of the stress-free reference configuration, ``t0 = dX/ds``."""
    J = ufl.Jacobian(mesh)
    return J[:, 0] / ufl.sqrt(ufl.dot(J[:, 0], J[:, 0]))


def ds_(w, t0):
    """Derivative with respect to stress-free arc length: ``∂s w = grad(w) t0``."""
    return ufl.grad(w) * t0


def stretch_vector(u, t0):
    """``∂s r = t0 + ∂s u``, the current tangent scaled by the stretch."""
    return t0 + ds_(u, t0)


def stretch(u, t0):
    """``λ = |∂s r|``."""
    g = stretch_vector(u, t0)
    return ufl.sqrt(ufl.dot(g, g))


def axial_strain(u, t0, c=1.0):
    """Axial (engineering) strain against the stress-free length, ``v3 = λ/c − 1``."""
    return stretch(u, t0) / c - 1.0


def tension(u, t0, EA, tension_only: bool = True, c=1.0):
    """Tension ``T = EA v3``; a tension-only cable carries no compression (``T >= 0``)."""
    v3 = axial_strain(u, t0, c)
    if tension_only:
        return ufl.conditional(ufl.gt(v3, 0.0), EA * v3, 0.0)
    return EA * v3


def _law_tension(lam, cos, law):
    """The layer law's tension at stretch ``lam`` and cosine ``cos`` (both signs)."""
    dc = ufl.max_value(ufl.min_value(cos - law.cos_ref, law.dcos), -law.dcos)
    rho = law.a - law.b * dc
    T_a = (lam - rho) / law.ka
    T_f = (lam - rho - (law.ka - law.kb) * law.tf) / law.kb
    T_c = (lam - rho - (law.ka - law.kb) * law.tc) / law.kb
    return ufl.max_value(ufl.min_value(T_a, T_f), T_c)


def layer_stretch_vector(u, t0, law, T=None):
    """The direction of a virtual hinge's region cell's force, with the hinge's normal
    offset (:mod:`cablefem.hinge`): the string starts on the rod's far-field line, which
    passes ``δn = D_n(T, Δ) − h sin Δ`` off the fixed node, normal to the string in the
    plane of the clamp direction ``c`` (``law.dir``, signed by the cell's orientation) and
    the string. Each region cell takes its share of it, ``∂s r − q (c − (c·e) e)``, with
    ``c − (c·e) e = sin Δ n`` and ``q = qT (T − T0) + qC (cos Δ − cos Δ0)`` linearised about
    the cell's static state (``law.qT``, ``law.qC``: zero outside the regions and in
    statics). ``T`` and ``cos Δ`` are the cell's own under the layer's law, from its chord
    ``∂s r`` (within the law's range): the shift is normal to the chord, so it changes the
    stretch only at second order, and the law keeps reading its chord. Without it the node
    stays where statics put it and the in-plane modes of a sagging cable with horizontal
    clamps come out 1-2 % low (the far field's normal shift is a first-order change of the
    length a curved span needs). ``T``: the law's tension with compression allowed
    (:func:`layer_law_tension`, ``tension_only=False``) when the caller has it."""
    g = stretch_vector(u, t0)
    lam = ufl.sqrt(ufl.dot(g, g))
    e = g / lam
    cos = ufl.dot(law.dir, e)
    if T is None:
        T = _law_tension(lam, cos, law)
    T = ufl.max_value(ufl.min_value(T, law.tc), law.tf)
    dc = ufl.max_value(ufl.min_value(cos - law.cos_ref, law.dcos), -law.dcos)
    q = law.qT * (T - law.tref) + law.qC * dc
    return g - q * (law.dir - cos * e)


def layer_law_tension(u, t0, law, tension_only: bool = True):
    """Tension under the virtual hinges' layer law (:mod:`cablefem.hinge`), a piecewise
    linear law in the stretch ``λ`` whose cell coefficients are in ``law`` (an object with
    the attributes ``a, b, ka, kb, tf, tc, dir, cos_ref, dcos``). Following the layer,
    ``λ = ρ + ka T`` with ``ρ = a − b clip(cos − cos_ref, ±dcos)`` (``cos = dir · ∂s r/λ``);
    below the floor tension ``tf`` and above the ceiling ``tc`` the elastic slope ``kb``
    (< ``ka``) through the same point at ``tf`` and ``tc``: ``T = max(min(T_a, T_f), T_c)``.
    With ``b = tf = tc = 0`` and ``ka = kb = c/EA``, ``a = c``, it is the elastic law
    ``EA (λ/c − 1)``."""
    g = stretch_vector(u, t0)
    lam = ufl.sqrt(ufl.dot(g, g))
    T = _law_tension(lam, ufl.dot(law.dir, g) / lam, law)
    if tension_only:
        return ufl.max_value(T, 0.0)
    return T


def internal_force(u, t0, EA, tension_only: bool = True, c=1.0, T=None, g=None):
    """Internal force vector ``N = T ∂s r / λ`` (``T``: a tension to use instead of
    :func:`tension`'s; ``g``: a stretch vector to use instead of ``∂s r``)."""
    if g is None:
        g = stretch_vector(u, t0)
    if T is None:
        T = tension(u, t0, EA, tension_only, c)
    return T * g / ufl.sqrt(ufl.dot(g, g))


def internal_work(u, du, t0, EA, tension_only: bool = True, dx=ufl.dx, c=1.0, T=None,
                  g=None):
    """Internal virtual work ``∫ N · ∂s δu ds`` (``∂s`` along the mesh: the stress-free
    measure ``c ds`` and derivative ``∂s / c`` cancel)."""
    return ufl.inner(internal_force(u, t0, EA, tension_only, c, T, g), ds_(du, t0)) * dx


def inertia_work(m, a, du, dx=ufl.dx, c=1.0):
    """Virtual work of the inertia forces ``∫ m ü · δu c ds`` (consistent mass)."""
    return c * m * ufl.inner(a, du) * dx


def load_work(f, du, dx=ufl.dx, c=1.0):
    """Virtual work of a distributed load ``∫ f · δu c ds`` (``f`` per stress-free length)."""
    return c * ufl.inner(f, du) * dx


def strain_rate(u, v, t0, c=1.0):
    """Rate of axial strain ``dv3/dt = (∂s r · ∂s v) / (c λ)``."""
    g = stretch_vector(u, t0)
    return ufl.dot(g, ds_(v, t0)) / ufl.sqrt(ufl.dot(g, g)) / c


def axial_damping_work(u, v, du, t0, EA, beta, dx=ufl.dx, c=1.0):
    """Axial strain-rate damping ``N_d = β EA (dv3/dt) ∂s r / λ`` (model "axial").

    This damps axial stretching only: taut transverse modes stay undamped (docs/theory.md
    §2), which is why it is not the default.
    """
    g = stretch_vector(u, t0)
    nd = beta * EA * strain_rate(u, v, t0, c) * g / ufl.sqrt(ufl.dot(g, g))
    return ufl.inner(nd, ds_(du, t0)) * dx


def strain_energy_density(u, t0, EA, tension_only: bool = True, c=1.0):
    """Strain energy per mesh length, ``c EA v3² / 2`` (tension part only if
    tension-only)."""
    v3 = axial_strain(u, t0, c)
    if tension_only:
        return ufl.conditional(ufl.gt(v3, 0.0), 0.5 * c * EA * v3 * v3, 0.0)
    return 0.5 * c * EA * v3 * v3


# ----------------------------------------------------------------------------- the residuals
MODEL_TERMS = ("internal", "external", "inertia", "damping")  #: the model's own (reserved)
#: the compiled objects, as :meth:`CableForms.compile` names them
COMPILED = ("f_static", "j_static", "f_dynamic", "j_dynamic", "m_form", "tension_expr",
            "strain_expr")
#: compiled on first use: the modal analysis' stiffness and damping, the statics' twins
#: with compression allowed and the energies (a run needing none compiles none)
ON_DEMAND = ("k_dynamic", "c_form", "f_static_bilateral", "j_static_bilateral",
             "energy_forms", "j_dynamic_fast", "j_dynamic_slow")


class CableForms:
    """The residual of a model as terms (:class:`cablefem.terms.Term`), and every form
    derived from them.

    Sign convention: the residual is ``internal − external + inertia + damping + Σ terms``
    and the solvers find where it vanishes; a term is added as it enters the residual (a
    load ``f`` as ``−f·δu``, a dashpot ``c v`` as ``+c v·δu``).

    The model supplies its own terms (:meth:`set_model_terms`); its physics (fluid,
    seabed, dampers, span bending) and a user add terms with :meth:`add`; :meth:`compile`
    derives and compiles everything the solvers read:

    * ``F_static = internal − external + Σ static terms`` and ``J_static = ∂F_static/∂u``;
    * their bilateral twins (the internal work with compression allowed), which statics
      uses to leave a guess on which every element is slack;
    * ``F_dynamic = inertia + internal − external + damping + Σ static + Σ dynamic terms``
      and the Jacobian of the time integrator, ``∂F/∂u + shift_a ∂F/∂a + shift_v ∂F/∂v``
      with a ``v`` (``a``) part whenever ``F_dynamic`` depends on ``v`` (``a``);
    * the mass form ``M = ∂F_dynamic/∂a`` (the inertia and any dynamic term in ``a``);
    * the output expressions (tension, strain) and the energy forms of the model.

    What the solvers ask of the terms: :meth:`set_time` (every term's time law and the time
    Constant :attr:`time`), :meth:`linearised` (the modal analysis' state),
    :attr:`mass_moves` (the anchor reactions' mass matrix) and :attr:`medium_forms` (the
    forces a kink's sides share).

    The UFL forms stay readable (``forms.F_dynamic``, ``forms.J_dynamic``, ...); they are
    derived from the terms at every access, never stored: editing them changes nothing.
    """

    def __init__(self, u, v, a, test, trial, shift_v, shift_a, points):
        self.u, self.v, self.a = u, v, a
        self.test, self.trial = test, trial
        self.shift_v, self.shift_a = shift_v, shift_a
        self.points = points  #: where output expressions are evaluated (the DG0 points)
        #: the model's cell measure; one with a quadrature degree (the rod's one point) fixes
        #: the rule of every cell integral (see :meth:`add`)
        self.dx = ufl.dx
        self.internal = self.internal_bilateral = self.external = None
        self.inertia = self.damping = None
        self._terms: dict[str, Term] = {}  # name -> Term, in the order added
        self._time = None  # the time Constant (created on first use of .time)
        self._t = None  # the time last set
        #: output expressions by name, compiled to ``<name>_expr`` (tension, strain)
        self.outputs: dict[str, ufl.core.expr.Expr] = {}
        #: kinetic, strain and gravity potential energy (UFL functionals of the model)
        self.energies: tuple = ()
        self._changes = 0  # bumped by every change of a term
        self._compiled_at = -1
        self._compiled: dict[str, object] = {}
        self._rates: dict = {}  # F_dynamic's dependence on v, a (_dynamic_depends_on)

    # ------------------------------------------------------------------ terms
    def set_model_terms(self, internal, external, inertia, damping=None,
                        internal_bilateral=None) -> None:
        """The model's own terms (for model builders): internal work, external work of the
        loads (positive: it is subtracted), inertia, damping (or None) and the internal
        work with compression allowed (None: the same as ``internal``)."""
        self.internal, self.external, self.inertia = internal, external, inertia
        self.damping, self.internal_bilateral = damping, internal_bilateral
        self._changes += 1

    def add(self, term: Term | str, form=None, kind: str = "static") -> None:
        """Add a :class:`~cablefem.terms.Term` (its form, kind, time law, linearisation,
        mass and medium flags), or the term ``form`` of ``kind`` under the name ``term``
        (``add(name, form, kind)``: a term with no time law, linearised as it stands).

        ``kind="static"``: a force of the configuration (a load, a spring): it acts in
        statics and in dynamics, and may depend on ``u`` only (not ``v`` or ``a``).
        ``kind="dynamic"``: it acts in dynamics only (a dashpot ``c v``, an added mass
        ``m_a a``, a load that starts with the motion); linear in ``a`` if it depends on it.

        A term with a time law is set to the model's current time at once. Every Jacobian
        is derived again at the next :meth:`compile` (or on the next access of a compiled
        form). ValueError (naming the term) when it is not a residual term of its kind."""
        if not isinstance(term, Term):
            term = Term(term, form, kind)
        elif form is not None:
            raise TypeError("add(term) takes a Term alone, add(name, form, kind) a name")
        name = term.name
        if not isinstance(name, str) or not name or name in MODEL_TERMS or name in self._terms:
            raise ValueError(f"term name {name!r} is empty, reserved {MODEL_TERMS} or taken "
                             f"(terms: {sorted(self._terms)}): remove it first")
        term = checked(term, self.test, self.u, self.v, self.a, self.dx, self._time)
        self._terms[name] = term
        if term.set_time is not None and self._t is not None:
            term.set_time(self._t)
        self._changes += 1

    def remove(self, name: str) -> None:
        """Remove the term ``name``."""
        if name not in self._terms:
            raise KeyError(f"no user term {name!r} (terms: {sorted(self._terms)})")
        del self._terms[name]
        self._changes += 1

    def term(self, name: str) -> Term:
        """The added term ``name`` as stored (derivatives expanded, ``moves_mass`` set)."""
        return self._terms[name]

    @property
    def user(self) -> dict[str, tuple[ufl.Form, str]]:
        """The added terms, name -> (form, kind), in the order added (a copy)."""
        return {name: (t.form, t.kind) for name, t in self._terms.items()}

    # ------------------------------------------------------------------ what solvers ask
    @property
    def time(self):
        """The time as a UFL Constant (created on first use), set by :meth:`set_time`: a
        term may use it in its form (``q0 * ufl.sin(w * model.forms.time)``), as dolfiny's
        time-dependent forms do."""
        if self._time is None:
            from dolfinx import fem

            self._time = fem.Constant(self.u.function_space.mesh,
                                      0.0 if self._t is None else float(self._t))
        return self._time

    def set_time(self, t: float) -> None:
        """Set the time Constant and call every term's time law at time ``t``."""
        self._t = t
        if self._time is not None:
            self._time.value = t
        for term in self._terms.values():
            if term.set_time is not None:
                term.set_time(t)

    @contextlib.contextmanager
    def linearised(self):
        """Within the block every term is at the state the modal analysis linearises about
        (each term's ``linearised()`` entered, in the order the terms were added)."""
        with contextlib.ExitStack() as stack:
            for term in self._terms.values():
                if term.linearised is not None:
                    stack.enter_context(term.linearised())
            yield

    @property
    def mass_moves(self) -> bool:
        """True when a term's mass changes with the state or with time (``moves_mass``):
        the mass matrix must be assembled again where it is used."""
        return any(t.moves_mass for t in self._terms.values())

    @property
    def medium_forms(self) -> tuple:
        """The forms of the terms of the medium (``medium=True``: the fluid's, the
        seabed's), in the order added."""
        return tuple(t.form for t in self._terms.values() if t.medium)

    @property
    def terms(self) -> dict[str, tuple[ufl.Form, str]]:
        """Every term of the residuals, name -> (form, kind), the model's first (external
        with the sign it has in the residual)."""
        out = {"internal": (self.internal, "internal"),
               "external": (-self.external, "external"), "inertia": (self.inertia, "inertia")}
        if self.damping is not None:
            out["damping"] = (self.damping, "damping")
        out.update(self.user)
        return out

    def _sum(self, start, kinds, keep=None):
        for term in self._terms.values():
            if term.kind in kinds and (keep is None or keep(term)):
                start = start + term.form
        return start

    # ------------------------------------------------------------------ derived UFL
    @property
    def F_static(self):
        return self._sum(self.internal - self.external, ("static",))

    @property
    def F_static_bilateral(self):
        if self.internal_bilateral is None:
            return self.F_static
        return self._sum(self.internal_bilateral - self.external, ("static",))

    @property
    def J_static(self):
        return ufl.derivative(self.F_static, self.u, self.trial)

    @property
    def J_static_bilateral(self):
        return ufl.derivative(self.F_static_bilateral, self.u, self.trial)

    @property
    def F_dynamic(self):
        return self._dynamic()

    def _dynamic(self, keep=None):
        F = self.inertia + self.internal - self.external
        if self.damping is not None:
            F = F + self.damping
        return self._sum(F, KINDS, keep)

    @property
    def J_dynamic(self):
        """``∂F/∂u + shift_a ∂F/∂a + shift_v ∂F/∂v``, a rate's part where F depends on it."""
        return _rates_jacobian(self, self.F_dynamic)

    def J_dynamic_part(self, slow: bool):
        """The part of ``J_dynamic`` of the terms of ``slow_jacobian`` (``slow``) or of all
        the others, None when no term is slow: a time integrator refreshes the fast part
        while it keeps the slow one (:mod:`cablefem.stepnewton`; compiled on demand as
        ``j_dynamic_slow``, ``j_dynamic_fast``)."""
        terms = [t for t in self._terms.values() if t.slow_jacobian and t.kind in KINDS]
        if not terms:
            return None
        if slow:
            return _rates_jacobian(self, sum((t.form for t in terms[1:]), terms[0].form))
        return _rates_jacobian(self, self._dynamic(lambda t: not t.slow_jacobian))

    def _dynamic_depends_on(self, w) -> bool:
        """``F_dynamic`` depends on ``w`` (v, a): one of its parts does; remembered."""
        parts = [p for p in (self.inertia, self.internal, self.external, self.damping, *(
            t.form for t in self._terms.values() if t.kind in KINDS)) if p is not None]
        if (key := (id(w), *map(id, parts))) not in self._rates:  # parts kept: ids theirs
            self._rates[key] = (any(depends_on(p, w, self.trial) for p in parts), parts)
        return self._rates[key][0]

    @property
    def K_dynamic(self):
        """``∂F_dynamic/∂u``: with ``v = a = 0`` the stiffness of the motion about a state
        at rest (the static tangent plus the dynamic terms' stiffness, e.g. dampers'
        springs); the modal analysis' ``K``."""
        return ufl.derivative(self.F_dynamic, self.u, self.trial)

    @property
    def C_form(self):
        """``∂F_dynamic/∂v``: the damping matrix (Rayleigh, dampers, any dynamic term in
        ``v``); None when ``F_dynamic`` does not depend on ``v``."""
        if not self._dynamic_depends_on(self.v):
            return None
        return ufl.derivative(self.F_dynamic, self.v, self.trial)

    @property
    def M_form(self):
        """The mass form ``∂F_dynamic/∂a``: the inertia and the dynamic terms in ``a``."""
        M = self.inertia
        for term in self._terms.values():
            if term.kind == "dynamic" and depends_on(term.form, self.a, self.trial):
                M = M + term.form
        return ufl.derivative(M, self.a, self.trial)

    # ------------------------------------------------------------------ compiled
    @property
    def stale(self) -> bool:
        """True when a term changed since the last :meth:`compile`."""
        return self._compiled_at != self._changes

    def compile(self) -> None:
        """Derive every form from the terms and JIT-compile it (FFCx caches the code: a
        form compiled before takes milliseconds). Collective on the mesh's communicator."""
        from dolfinx import fem

        from cablefem.jit import quiet_compiler

        with quiet_compiler():
            out = {n: _form(self._ufl(n)) for n in COMPILED if not n.endswith("_expr")}
            for name, expr in self.outputs.items():
                out[f"{name}_expr"] = fem.Expression(expr, self.points)
        self._compiled = out
        self._compiled_at = self._changes

    def __getattr__(self, name: str):
        # compiled again first when a term changed since; those of ON_DEMAND on first use
        if name.startswith("_") or not (name in COMPILED or name in ON_DEMAND
                                        or name.endswith("_expr")):
            raise AttributeError(name)
        if self.stale:
            self.compile()
        if name in ON_DEMAND and name not in self._compiled:
            self._compiled[name] = self._compile_on_demand(name)
        try:
            return self._compiled[name]
        except KeyError:
            raise AttributeError(f"no compiled {name!r}") from None

    def _compile_on_demand(self, name: str):
        """One of :data:`ON_DEMAND` compiled (``c_form`` None: no damping)."""
        from dolfinx import fem

        from cablefem.jit import quiet_compiler
        if name.endswith("_bilateral") and self.internal_bilateral is None:
            return self._compiled[name[:-len("_bilateral")]]  # the same forms
        with quiet_compiler():
            if name == "energy_forms":
                return tuple(fem.form(e) for e in self.energies)
            form = self._ufl(name)
            return None if form is None else _form(form)

    def _ufl(self, name: str):
        """The UFL form compiled as ``name`` (``f_static``: ``F_static``, ...)."""
        if name.startswith("j_dynamic_"):  # j_dynamic_fast, j_dynamic_slow
            return self.J_dynamic_part(name == "j_dynamic_slow")
        return getattr(self, name[0].upper() + name[1:])


def _rates_jacobian(forms: CableForms, F):
    """``∂F/∂u + shift_a ∂F/∂a + shift_v ∂F/∂v`` of ``F`` (``forms.F_dynamic`` or a part
    of it), a rate's part wherever ``F_dynamic`` depends on that rate."""
    dw = forms.trial
    J = ufl.derivative(F, forms.u, dw)
    if forms._dynamic_depends_on(forms.a):
        J = J + forms.shift_a * ufl.derivative(F, forms.a, dw)
    if forms._dynamic_depends_on(forms.v):
        J = J + forms.shift_v * ufl.derivative(F, forms.v, dw)
    return J


def _form(form):
    """``dolfinx.fem.form(form)`` with the form's Constants noted as ``cablefem_constants``
    (dolfinx's own objects, in the order dolfinx packs them), so that a packing of them can
    be kept and refreshed only when one changed (:mod:`cablefem.native_rows`)."""
    from dolfinx import fem

    compiled = fem.form(form)
    compiled.cablefem_constants = [c._cpp_object for c in form.constants()]
    return compiled
