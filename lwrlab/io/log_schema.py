"""The names and units of the recorded-log schema, and the error every log reader raises.

The bottom of :mod:`lwrlab.io`'s log modules: the loader (:mod:`lwrlab.io.logs`), the format
readers (:mod:`lwrlab.io.log_formats`, :mod:`lwrlab.io.rosbag`) and the checks
(:mod:`lwrlab.io.plausibility` and its helpers) all name columns and rows the same way and fail with
:class:`LogError`; they import it from here, so that no arrow points back up to the loader. The
schema itself (columns, units, validation) is documented in :mod:`lwrlab.io.logs`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lwrlab.errors import UserError

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
"""Seconds per unit of the time column."""
POSITION_UNITS = {"rad": 1.0, "deg": np.pi / 180.0}
"""Radians per unit of the position (and velocity) columns."""


class LogError(UserError, ValueError):
    """A malformed or implausible log; the message names the file, the column and the row or check."""


def joint_columns(prefix: str, n_joints: int) -> list[str]:
    """Schema column names ``prefix1 … prefixN``."""
    return [f"{prefix}{j}" for j in range(1, n_joints + 1)]


def row_location(path: Path, row: int) -> str:
    """``row 41`` of a log's data, with the file's line for text files (``(line 43 of the file)``)."""
    line = f" (line {row + 2} of the file)" if path.suffix.lower() in (".csv", ".txt") else ""
    return f"row {row}{line}"
