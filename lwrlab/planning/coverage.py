"""Painted coverage of a wall region from the tool's contact trace (Fig. 12)."""

from __future__ import annotations

import numpy as np

GRID_CELL = 0.002
"""Cell size (m) of the coverage grid: a constant of the measure, not a setting (finer than the
~4 mm lateral tracking error in contact)."""


def painted_fraction(
    y: np.ndarray,
    z: np.ndarray,
    in_contact: np.ndarray,
    roller_width: float,
    region: tuple[float, float, float, float],
    resolution: float = GRID_CELL,
) -> tuple[float, np.ndarray]:
    """Fraction of ``region`` the roller painted, and the painted grid.

    The roller paints, at every sample in contact, the cells of its contact line: ``|y' − y| ≤ w/2``
    at the row of ``z`` (the trace moves far less than a cell per sample at 1 kHz, so consecutive rows
    join up).

    Parameters
    ----------
    y, z : (N,) contact-line centre on the wall (m).
    in_contact : (N,) True where the roller presses on the wall.
    roller_width : w_L (m).
    region : (y_min, y_max, z_min, z_max) the area meant to be painted (m).
    resolution : grid cell size (m): the measure's constant :data:`GRID_CELL`.

    Returns
    -------
    fraction : painted share of the region's cells (0 … 1).
    painted : (n_z, n_y) boolean grid, row 0 at z_min.
    """
    y_min, y_max, z_min, z_max = region
    if y_max <= y_min or z_max <= z_min:
        raise ValueError(f"empty coverage region {region}")
    y_cells = np.arange(y_min + resolution / 2, y_max, resolution)
    n_z = max(int(np.ceil((z_max - z_min) / resolution)), 1)
    painted = np.zeros((n_z, y_cells.size), dtype=bool)
    rows = np.floor((np.asarray(z) - z_min) / resolution).astype(int)
    keep = np.asarray(in_contact, dtype=bool) & (rows >= 0) & (rows < n_z)
    half = roller_width / 2
    first = np.searchsorted(y_cells, np.asarray(y) - half, side="left")
    last = np.searchsorted(y_cells, np.asarray(y) + half, side="right")
    for row, a, b in zip(rows[keep], first[keep], last[keep], strict=True):
        painted[row, a:b] = True
    return float(painted.mean()), painted
