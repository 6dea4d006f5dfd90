"""Just-in-time compilation of forms and elements (FFCx), quietly.

FFCx compiles every UFL form and finite element to C the first time it is used and caches
the result; :func:`quiet_compiler` keeps the C compiler's messages off the console meanwhile,
:func:`mixed_rules` lets FFCx 0.5 compile a kernel whose terms use different Gauss rules,
and :func:`direct_cache_lookup` has it load a cached kernel without listing the cache.
"""

from __future__ import annotations

import contextlib
import importlib.machinery
import importlib.util
import logging
import os
import time
from pathlib import Path

__all__ = ["quiet_compiler", "mixed_rules", "direct_cache_lookup"]


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
    direct_cache_lookup()
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


_DIRECT: bool | None = None


def direct_cache_lookup() -> bool:
    """Have FFCx 0.5 load a kernel from its cache by the file's own name; True when it
    does (idempotent; the first call replaces ``ffcx.codegeneration.jit.get_cached_module``).

    FFCx 0.5 finds a cached module with a new ``importlib`` ``FileFinder`` at every form,
    which lists the whole cache folder: with the ~10 000 files a cache gathers (four per
    kernel) that is 10 ms a form, 0.17 s of building paper case B's model. The module is a
    known file, ``<cache>/<module>`` plus an extension suffix: looking for those few names
    finds the same file. Everything else is FFCx's: the C file created exclusively by the
    process that compiles, the wait for its ``.c.cached`` marker, the same errors."""
    global _DIRECT
    if _DIRECT is None:
        _DIRECT = _patch_cache_lookup()
    return _DIRECT


def _cached_module(module_name, object_names, cache_dir, timeout):
    """FFCx 0.5's ``get_cached_module``, the module found by its file name."""
    cache_dir = Path(cache_dir)
    c_file = cache_dir / f"{module_name}.c"
    ready = cache_dir / f"{module_name}.c.cached"
    cache_dir.mkdir(exist_ok=True, parents=True)
    try:
        open(c_file, "x").close()  # this process compiles it
        return None, None
    except FileExistsError:
        pass
    for _ in range(timeout):
        if ready.exists():
            for suffix in importlib.machinery.EXTENSION_SUFFIXES:
                path = cache_dir / f"{module_name}{suffix}"
                if path.is_file():
                    break
            else:
                raise ModuleNotFoundError("Unable to find JIT module.")
            loader = importlib.machinery.ExtensionFileLoader(module_name, os.fspath(path))
            spec = importlib.util.spec_from_file_location(module_name, os.fspath(path),
                                                          loader=loader)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            return [getattr(module.lib, name) for name in object_names], module
        time.sleep(1)
    raise TimeoutError(f"JIT compilation timed out, probably after a failed compile: remove "
                       f"{c_file} or raise the timeout")


def _patch_cache_lookup() -> bool:
    try:
        import ffcx
        from ffcx.codegeneration import jit
    except ImportError:
        return False
    if not ffcx.__version__.startswith("0.5.") or not hasattr(jit, "get_cached_module"):
        return False
    jit.get_cached_module = _cached_module
    return True
