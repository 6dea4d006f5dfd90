"""Rank-0 logging and a progress bar with ETA for long runs.

Every module logs through ``logging.getLogger(__name__)`` (children of ``cablefem``);
:func:`setup_logging` attaches one handler that lets records through on rank 0 only, so
that an MPI run prints each message once.
"""

from __future__ import annotations

import logging
import sys
import time

from mpi4py import MPI

from cablefem.jit import quiet_compiler  # noqa: F401 - re-exported

__all__ = ["setup_logging", "Progress", "quiet_compiler"]


class _RankZeroFilter(logging.Filter):
    def __init__(self, comm: MPI.Comm) -> None:
        super().__init__()
        self.rank = comm.rank

    def filter(self, record: logging.LogRecord) -> bool:  # noqa: A003 - logging API
        return self.rank == 0


class _StderrHandler(logging.StreamHandler):
    """A StreamHandler on whatever ``sys.stderr`` is at the time of each record (not the
    one at set-up: a test runner or a notebook may replace it and close the old one)."""

    def __init__(self) -> None:
        super().__init__(sys.stderr)

    @property
    def stream(self):  # noqa: D401 - logging's attribute
        return sys.stderr

    @stream.setter
    def stream(self, value) -> None:  # set by StreamHandler.__init__; always sys.stderr
        pass


def setup_logging(level: int = logging.INFO, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Send ``cablefem`` log records to stderr, from rank 0 only (idempotent)."""
    logger = logging.getLogger("cablefem")
    logger.setLevel(level)
    if not any(getattr(h, "_cablefem", False) for h in logger.handlers):
        handler = _StderrHandler()
        handler.setFormatter(logging.Formatter("[cablefem] %(message)s"))
        handler.addFilter(_RankZeroFilter(comm))
        handler._cablefem = True  # type: ignore[attr-defined]
        logger.addHandler(handler)
    logger.propagate = False


class Progress:
    """A text progress bar with ETA, printed on rank 0 to stderr.

    On a terminal the bar redraws in place; otherwise (logs, CI) a line is printed every
    ``every_s`` seconds of wall time, so long runs show they are alive without flooding.
    """

    def __init__(self, total: float, label: str = "", comm: MPI.Comm = MPI.COMM_WORLD,
                 enabled: bool = True, every_s: float = 10.0) -> None:
        self.total = float(total)
        self.label = label
        self.enabled = enabled and comm.rank == 0
        self.tty = sys.stderr.isatty()
        self.every_s = every_s
        self.t0 = time.perf_counter()
        self._last = -1e30

    def update(self, done: float, info: str = "") -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if not self.tty and now - self._last < self.every_s and done < self.total:
            return
        if self.tty and now - self._last < 0.1 and done < self.total:
            return
        self._last = now
        frac = min(max(done / self.total, 0.0), 1.0) if self.total > 0 else 1.0
        elapsed = now - self.t0
        # no estimate before any progress: say so rather than print "nan"
        eta = f"{elapsed * (1.0 - frac) / frac:7.1f} s" if frac > 0 else "    n/a  "
        width = 30
        bar = "#" * int(round(frac * width))
        text = (f"{self.label} [{bar:<{width}}] {100 * frac:5.1f}% "
                f"elapsed {elapsed:7.1f} s, ETA {eta} {info}")
        if self.tty:
            sys.stderr.write("\r" + text)
            if frac >= 1.0:
                sys.stderr.write("\n")
        else:
            sys.stderr.write(text + "\n")
        sys.stderr.flush()

    def close(self) -> None:
        if self.enabled and self.tty:
            sys.stderr.write("\n")
            sys.stderr.flush()
