"""``summary.json`` and the other JSON outputs: NumPy and dataclass values made JSON-able,
written atomically by rank 0."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
from mpi4py import MPI


def jsonable(obj):
    """Convert numpy scalars/arrays and non-finite floats to plain JSON values.

    Args:
        obj: A value, or dicts and lists of them (converted recursively).

    Returns:
        The value with NumPy types as Python ones and non-finite floats as None.
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path: Path, data: dict, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Write ``data`` as JSON from rank 0, atomically; collective (all ranks call it).

    Args:
        path: The JSON file.
        data: The values (made JSON-able with :func:`jsonable`).
        comm: MPI communicator.
    """
    if comm.rank == 0:
        path = Path(path)
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(json.dumps(jsonable(data), indent=2) + "\n")
        os.replace(tmp, path)
    comm.Barrier()
