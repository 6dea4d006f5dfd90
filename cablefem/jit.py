"""Just-in-time compilation of forms and elements (FFCx), quietly.

FFCx compiles every UFL form and finite element to C the first time it is used and caches
the result; :func:`quiet_compiler` keeps the C compiler's messages off the console meanwhile.
"""

from __future__ import annotations

import contextlib
import logging

__all__ = ["quiet_compiler"]


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
    restored afterwards, so a user's own logging set-up is untouched."""
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
