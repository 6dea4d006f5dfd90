"""The validity of the modal table (docs/theory.md §5.3): each mode's estimated frequency
error and whether its wavelength is long against the clamps' boundary layers, with a warning
naming the modes outside the method's range.

The string with its layers describes a mode whose wavelength is long against the layer
length ``ell = sqrt(EI/T)`` at the clamps: ``k ell`` small, ``k = omega sqrt(m/T)`` the
mode's wavenumber there. A clamped end's bending decays over ``ell / sqrt(1 + (k ell)^2)``
for a wave of wavenumber ``k`` (a taut beam: ``T k^2 + EI k^4 = m omega^2`` with the
evanescent root), not over the static ``ell`` that the virtual hinge places the string's end
at: each end is off by ``ell (k ell)^2/2`` to first order, a frequency error of
``e1 (k ell)^2/2`` with ``e1 = sum over the clamped ends of h/l`` (h the hinge offset,
l the cable's length; in a network twice the largest, a cable having two ends). A mode's
estimated relative frequency error adds, as the anchor moment's estimate does (§5.1),
the outer problem's next order (``e1``, its square with the virtual hinge),
``e1 (k ell)^2/2``, the span's bending measured on the mode when it is off
(``span_bending_shift``) and the mesh's P1 error (:mod:`cablefem.discretisation`).
"""

from __future__ import annotations

import numpy as np

from cablefem import asymptotics
from cablefem.discretisation import mode_mesh_errors

#: Largest ``k ell`` of a mode inside the method's range: there the layer's decay length
#: for the mode, ``ell / sqrt(1 + (k ell)^2)``, is within 11 % of the static one the string
#: uses (measured: the in-plane modes of a 10 %-sag cable are within 0.7 % of the rod up to
#: k ell = 0.38 at eps = 0.03, and 1.2 % to 22 % off from k ell = 0.69 at eps = 0.08).
MAX_LAYER_RATIO = 0.5


def _clamps(model, static) -> list[tuple[float, float, float, float]]:
    """(tension, EI, mass, e1 part h/l) of each clamped anchor in the static state."""
    out = []
    for a, F in zip(model.anchors, static.anchor_forces):
        if a.kind != "clamped":
            continue
        T = float(np.linalg.norm(np.asarray(F, float)[:3]))
        if not T > 0:
            continue
        delta = float(np.arccos(np.clip(np.asarray(F, float)[:3] @ a.direction / T, -1, 1)))
        h, _ = asymptotics.virtual_hinge(delta, T, a.section.EI, a.section.EA)
        out.append((T, a.section.EI, a.section.mass,
                    float(h) / (1 + T / a.section.EA) / model.anchor_span(a.name)))
    return out


def mode_validity(summary: dict, model, static, modal, warn, threshold: float,
                  outer_order: int) -> list[int]:
    """Add to every ``summary["modes"]`` entry ``layer_ratio`` (``k ell``, the largest over
    the clamped anchors), ``valid`` (``k ell <= MAX_LAYER_RATIO``) and ``error_estimate``
    (relative frequency error); warn (key ``modal``) naming the modes outside the range or
    with an estimate above ``threshold``. Returns those modes' numbers (1-based)."""
    clamps = _clamps(model, static)
    # a cable has at most two clamped ends: a network's many clamps do not add up
    e1 = min(len(clamps), 2) * max((c[3] for c in clamps), default=0.0)
    e_outer = e1 if outer_order == 0 else e1 * e1
    bad, meshes = [], {}
    mesh_errors = mode_mesh_errors(model, static, modal)  # collective for a network
    for i, (entry, w) in enumerate(zip(summary["modes"], modal.omegas)):
        kl = max((w * np.sqrt(m * EI) / T for T, EI, m, _ in clamps), default=0.0)
        mesh = abs(mesh_errors[i] or 0.0)
        est = e_outer + e1 * kl * kl / 2 + abs(entry.get("span_bending_shift", 0.0)) + mesh
        entry["error_estimate"] = float(est)
        meshes[i + 1] = mesh
        if clamps:
            entry["layer_ratio"] = float(kl)
            entry["valid"] = bool(kl <= MAX_LAYER_RATIO)
        if kl > MAX_LAYER_RATIO or est > threshold:
            bad.append(i + 1)
    if bad:
        worst = max(bad, key=lambda n: summary["modes"][n - 1]["error_estimate"])
        e = summary["modes"][worst - 1]
        why = (f"of that, the mesh's own {meshes[worst]:.1%} (linear elements: more "
               "mesh.elements reduce it as their length squared)"
               if meshes[worst] > e["error_estimate"] / 2 else
               "their wavelength is not long against the clamps' boundary layer (ell = "
               "sqrt(EI/T)), which the string leaves out (the rod, 'cablefem run --model "
               "beam', computes them)")
        warn(summary, "modal", f"{len(bad)} of {len(summary['modes'])} modes (number "
             f"{', '.join(map(str, bad))}) are outside the method's range or have an "
             f"estimated frequency error above {threshold:.0%} (mode {worst}: "
             f"{e['error_estimate']:.1%}, k ell = {e.get('layer_ratio', 0.0):.3g}; in range: "
             f"k ell <= {MAX_LAYER_RATIO:g}): {why}; see error_estimate and valid in "
             "summary.json's modes")
    return bad
