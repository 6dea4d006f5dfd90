"""Just-in-time compilation of forms and elements (FFCx), quietly.

FFCx compiles every UFL form and finite element to C the first time it is used and caches
the result; :func:`quiet_compiler` keeps the C compiler's messages off the console meanwhile,
and :func:`mixed_rules` lets FFCx 0.5 compile a kernel whose terms use different Gauss rules.
"""

from __future__ import annotations

import contextlib
import logging

__all__ = ["quiet_compiler", "mixed_rules"]


def _below_warning(record: logging.LogRecord) -> bool:
    return record.levelno >= logging.WARNING


@contextlib.contextmanager
def quiet_compiler():
    """Keep the C compiler's messages off the console while FFCx builds forms and elements.

    setuptools logs every compiler command at INFO through the *root* logger, which FFCx
    gives a console handler at import (``logging.basicConfig()``): "INFO:root:gcc ...". For
    the duration, a filter on the root logger itself drops its records below WARNING (a
    logger's filters see only the records logged on it, not those of other loggers passed
    up to its handlers), and a :class:`logging.NullHandler` keeps ``logging.info`` from
    installing a handler when there is none. The root's level, filters and handlers are
    restored afterwards, so a user's own logging set-up is untouched. FFCx is first made
    able to compile kernels of several Gauss rules (:func:`mixed_rules`)."""
    mixed_rules()  # every kernel may hold terms of different Gauss rules
    root = logging.getLogger()
    level = root.level
    null = logging.NullHandler()
    root.addHandler(null)
    root.addFilter(_below_warning)
    try:
        yield
    finally:
        root.removeFilter(_below_warning)
        root.removeHandler(null)
        root.setLevel(level)


_MIXED_RULES: bool | None = None


def mixed_rules() -> bool:
    """Let FFCx 0.5 compile a kernel whose cell integrals use different Gauss rules (the
    fluid's drag on a rule of its own, the string's and the seabed's terms on theirs);
    True when it can (idempotent; the first call patches FFCx's generator).

    FFCx 0.5 writes, per rule, the quantities constant on a cell (the geometry's Jacobian,
    a cell's coefficients) before the quadrature loops, all in one C scope: a second rule
    declares them again (``redefinition of 'J_c0'``, the C compiler fails). Being constant
    on the cell, their values do not depend on the rule, so the patch keeps the first
    rule's declarations and drops the repeats. Only FFCx 0.5's generator is patched (its
    ``IntegralGenerator.generate_piecewise_partition`` and ``fuse_loops``); with any
    other version False, and the terms share one rule (UFL's estimate).
    ``tests/test_fluid.py`` checks that such a kernel equals the sum of its integrals'
    own kernels to round-off."""
    global _MIXED_RULES
    if _MIXED_RULES is None:
        _MIXED_RULES = _patch_ffcx()
    return _MIXED_RULES


def _patch_ffcx() -> bool:
    try:
        import ffcx
        from ffcx.codegeneration.integrals import IntegralGenerator as Gen
    except ImportError:
        return False
    if not ffcx.__version__.startswith("0.5.") or not all(
            hasattr(Gen, name) for name in ("generate_piecewise_partition", "fuse_loops")):
        return False
    piecewise, fuse = Gen.generate_piecewise_partition, Gen.fuse_loops

    def generate_piecewise_partition(self, quadrature_rule):
        self._cablefem_piecewise = True
        try:
            return piecewise(self, quadrature_rule)
        finally:
            self._cablefem_piecewise = False

    def fuse_loops(self, definitions):
        if getattr(self, "_cablefem_piecewise", False):  # a cell constant: declared once
            seen = self.__dict__.setdefault("_cablefem_declared", set())
            definitions = {k: d for k, d in definitions.items() if k not in seen}
            seen.update(definitions)
        return fuse(self, definitions)

    Gen.generate_piecewise_partition = generate_piecewise_partition
    Gen.fuse_loops = fuse_loops
    return True
