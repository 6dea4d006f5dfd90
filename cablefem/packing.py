"""Where a form's coefficients sit in dolfinx's packing of them, so that a time integrator
can copy only what changed: the state Functions (:func:`state_gather`), the other Functions
that a time law changed (:func:`other_functions`, :func:`copy_changed`), and a Jacobian's
coefficients as columns of its residual's (:func:`jacobian_columns`, :func:`take_columns`).
Used by :class:`cablefem.petsc_utils.RowsAssembler`, whose results :mod:`cablefem.native_rows`
reads."""

from __future__ import annotations

import numpy as np
from dolfinx import cpp as dcpp
from dolfinx import fem

__all__ = ["state_gather", "other_functions", "copy_changed", "jacobian_columns",
           "take_columns"]


def other_functions(F: fem.FormMetaClass, state) -> list | None:
    """``F``'s Functions other than ``state``, each as (its values (a view), [their bytes
    as last packed], [(key, flat positions in the packing, indices into the values)]), for
    :meth:`RowsAssembler.coefficients`; [] when there are none, None when their places in
    the packing are not found exactly (:func:`state_gather`)."""
    held = [getattr(f, "_cpp_object", f) for f in state]
    others = [c for c in F.coefficients if all(c is not h for h in held)]
    if not others:
        return []
    where = state_gather(F, others)
    if where is None:
        return None
    out = []
    for i, c in enumerate(others):
        arr = c.x.array
        items = [(key, items[i][0], items[i][2]) for key, items in where.items()
                 if items[i][0].size]
        out.append((arr, [arr.tobytes()], items))
    return out


def copy_changed(packed: dict, others: list) -> None:
    """Copy into ``packed`` the values of those of ``others`` (:func:`other_functions`)
    that changed since they were last packed, and note them. Compared byte for byte
    (14 arrays of 200 values: 5 µs, where ``np.array_equal`` took 60 µs)."""
    for arr, last, items in others:
        now = arr.tobytes()
        if now == last[0]:
            continue
        for key, pos, src in items:
            packed[key].reshape(-1)[pos] = arr[src]
        last[0] = now


def state_gather(F: fem.FormMetaClass, functions) -> dict | None:
    """Where each of ``functions`` (coefficients of ``F``) sits in ``F``'s packed
    coefficients: ``{key: [(flat positions, the function's local array (a view), indices
    into it)]}``, such that copying ``array[indices]`` to those positions of a packed array gives
    what packing afresh gives when only these functions changed; None when that does not
    hold (checked with random values; the values are restored). Found in one packing of
    every function's local indices, numbered on from one function to the next (the other
    coefficients -1)."""
    coeffs = list(F.coefficients)  # dolfinx's C++ Functions
    if not functions or any(all(getattr(f, "_cpp_object", f) is not c for c in coeffs)
                            for f in functions):
        return None
    arrays = [c.x.array for c in coeffs]
    saved = [a.copy() for a in arrays]
    try:
        out: dict = {}
        for a in arrays:
            a[:] = -1.0
        first = np.zeros(len(functions), np.int64)  # each function's first number
        total = 0
        for i, f in enumerate(functions):
            first[i] = total
            f.x.array[:] = np.arange(total, total + f.x.array.size, dtype=float)
            total += f.x.array.size
        for key, packed in dcpp.fem.pack_coefficients(F).items():
            flat = packed.reshape(-1)
            pos = np.flatnonzero(flat >= 0.0)
            number = flat[pos].astype(np.int64)
            owner = np.searchsorted(first, number, side="right") - 1
            out[key] = [(pos[owner == i], f, number[owner == i] - first[i])
                        for i, f in enumerate(functions)]
        # the Functions' arrays: views of their storage, held (an access costs 1 µs)
        out = {key: [(pos, f.x.array, src) for pos, f, src in items]
               for key, items in out.items()}
        rng = np.random.default_rng(1)
        for a in arrays:
            a[:] = rng.standard_normal(a.size)
        stale = {k: v.copy() for k, v in dcpp.fem.pack_coefficients(F).items()}
        for f in functions:
            f.x.array[:] = rng.standard_normal(f.x.array.size)
        fresh = dcpp.fem.pack_coefficients(F)
        for key, items in out.items():
            flat = stale[key].reshape(-1)
            for pos, arr, src in items:
                flat[pos] = arr[src]
        if set(stale) != set(fresh) or not all(np.array_equal(stale[k], fresh[k])
                                                for k in fresh):
            return None
        return out
    finally:
        for a, s in zip(arrays, saved):
            a[:] = s


def jacobian_columns(F: fem.FormMetaClass, J: fem.FormMetaClass) -> dict | None:
    """Where the Jacobian form ``J``'s packed coefficients sit in the residual form ``F``'s,
    per integral: ``{key: column indices}`` with ``pack(J)[key] == pack(F)[key][:, cols]``
    exactly whatever the coefficients' values, or None when that does not hold (then the
    Jacobian packs its own). Found by packing each coefficient's number, then checked with
    random values (the coefficients' values are restored)."""
    arrays = [c.x.array for c in F.coefficients]
    saved = [a.copy() for a in arrays]
    try:
        for k, a in enumerate(arrays):
            a[:] = k + 1.0
        pf, pj = dcpp.fem.pack_coefficients(F), dcpp.fem.pack_coefficients(J)
        if not set(pj) <= set(pf) or any(pf[k].shape[0] != pj[k].shape[0] for k in pj):
            return None
        cols = {}
        for key, packed in pj.items():
            if pf[key].shape[0] == 0:  # no entity on this rank: any columns of the width
                cols[key] = np.zeros(_records(packed, key).shape[1], np.int64)
                continue
            # coefficient number + 1 per column of an entity's record
            owner_f, owner_j = _records(pf[key], key)[0], _records(packed, key)[0]
            c = []
            for k in np.unique(owner_j):
                src, dst = np.flatnonzero(owner_f == k), np.flatnonzero(owner_j == k)
                if src.size != dst.size:
                    return None
                c.append((dst, src))
            idx = np.empty(owner_j.size, np.int64)
            for dst, src in c:
                idx[dst] = src
            cols[key] = idx
        rng = np.random.default_rng(0)
        for a in arrays:
            a[:] = rng.standard_normal(a.size)
        pf, pj = dcpp.fem.pack_coefficients(F), dcpp.fem.pack_coefficients(J)
        taken = take_columns(pf, cols)
        if not all(np.array_equal(pj[k], taken[k]) for k in cols):
            return None
        return cols
    finally:
        for a, s in zip(arrays, saved):
            a[:] = s


def _records(packed: np.ndarray, key) -> np.ndarray:
    """A packing with one row per integration entity: an interior facet's values (both
    cells') fill two rows of the array dolfinx 0.5 returns, one record of twice the width."""
    if key[0] == dcpp.fem.IntegralType.interior_facet:
        return packed.reshape(packed.shape[0] // 2, 2 * packed.shape[1])
    return packed


def take_columns(packed: dict, cols: dict) -> dict:
    """The packing of a form whose coefficients are columns ``cols`` (of each entity's
    record, :func:`jacobian_columns`) of the packing ``packed``, in dolfinx's shapes."""
    out = {}
    for key, idx in cols.items():
        rows, per_row = packed[key].shape[0], idx.size
        if key[0] == dcpp.fem.IntegralType.interior_facet:
            per_row //= 2
        out[key] = _records(packed[key], key)[:, idx].reshape(rows, per_row)
    return out
