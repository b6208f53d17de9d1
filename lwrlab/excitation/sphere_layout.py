"""The sphere pairs of a set of distance columns, flattened into one array for
:class:`~lwrlab.excitation.sphere_distances.SphereDistances`, and their smallest gaps at chosen
(column, sample) entries only.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SphereLayout:
    """Every sphere pair of some columns (pairs of one family), flattened: column ``sphere_columns[i]``
    is the run ``first, second [starts[i] : starts[i] + lengths[i]]`` of sphere indices, between the
    bounding spheres ``groups[i]``; analytic world columns are (column, world object, spheres, body)."""

    first: np.ndarray
    second: np.ndarray
    sphere_columns: np.ndarray
    starts: np.ndarray
    lengths: np.ndarray
    groups: np.ndarray
    analytic: list[tuple[int, int, np.ndarray, int]]

    @property
    def n_columns(self) -> int:
        return len(self.sphere_columns) + len(self.analytic)


def sphere_layout(
    family: str,
    pairs: tuple[tuple[int, int], ...],
    body_spheres: Sequence[np.ndarray],
    world_spheres: Mapping[int, np.ndarray],
    world_groups: Mapping[int, int],
) -> SphereLayout:
    """The layout of ``pairs`` (body pairs, or (body, world object) pairs for ``family`` "world"):
    ``body_spheres`` the sphere indices of each body, ``world_spheres`` those of each mesh world
    object (the others are analytic), ``world_groups`` each mesh world object's bounding sphere."""
    firsts, seconds, starts, lengths, groups, analytic = [], [], [], [], [], []
    count = 0
    for c, (a, b) in enumerate(pairs):
        first = body_spheres[a]
        if family == "world" and b not in world_spheres:
            analytic.append((c, b, first, a))
            continue
        second = body_spheres[b] if family == "self" else world_spheres[b]
        ia, ib = np.meshgrid(first, second, indexing="ij")
        firsts.append(ia.ravel())
        seconds.append(ib.ravel())
        starts.append(count)
        lengths.append(ia.size)
        groups.append((a, b if family == "self" else world_groups[b]))
        count += ia.size
    return SphereLayout(
        np.concatenate(firsts) if firsts else np.zeros(0, dtype=int),
        np.concatenate(seconds) if seconds else np.zeros(0, dtype=int),
        np.array([c for c in range(len(pairs)) if c not in {a[0] for a in analytic}], dtype=int),
        np.array(starts, dtype=int),
        np.array(lengths, dtype=int),
        np.reshape(groups, (-1, 2)).astype(int),
        analytic,
    )


def gaps_within(
    layout: SphereLayout,
    centres: np.ndarray,
    radii: np.ndarray,
    chosen: np.ndarray,
    out: np.ndarray,
    rows: np.ndarray | None = None,
) -> None:
    """Write into ``out`` (C, N) the smallest gap ``‖c_a − c_b‖ − r_a − r_b`` over each sphere
    column's sphere pairs, at the (run, sample) entries ``chosen`` (R, N) only (``centres``
    (S, N, 3), ``radii`` (S,)); ``rows``: the row of ``out`` of each of the layout's columns (default:
    the column itself)."""
    n = centres.shape[1]
    flat = np.ascontiguousarray(centres).reshape(-1, 3)
    for run in np.flatnonzero(chosen.any(axis=1)):
        samples = np.flatnonzero(chosen[run])
        pairs = slice(layout.starts[run], layout.starts[run] + layout.lengths[run])
        first, second = layout.first[pairs], layout.second[pairs]
        # a run's sphere pairs at its samples, gathered from the flattened centres (rows of 3)
        gap = np.take(flat, (first[:, None] * n + samples).ravel(), axis=0)
        gap -= np.take(flat, (second[:, None] * n + samples).ravel(), axis=0)
        # the radii summed first, as SphereDistances._sphere_gaps: the same gaps to the last bit
        gaps = np.sqrt(np.einsum("mk,mk->m", gap, gap)).reshape(len(first), len(samples))
        column = layout.sphere_columns[run]
        out[column if rows is None else rows[column], samples] = np.min(
            gaps - (radii[first] + radii[second])[:, None], axis=0
        )


def nearest_pairs(
    layout: SphereLayout, centres: np.ndarray, radii: np.ndarray, run: np.ndarray, sample: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The sphere pair (first, second sphere indices, (E,) each) with the smallest gap of the sphere
    column ``run`` (E,) at sample ``sample`` (E,) of ``centres`` (S, N, 3): the first of equals, as
    ``argmin`` over the column's pairs picks it."""
    counts = layout.lengths[run]
    offsets = np.cumsum(counts) - counts
    flat = np.repeat(layout.starts[run] - offsets, counts) + np.arange(int(counts.sum()))
    first, second = layout.first[flat], layout.second[flat]
    samples = np.repeat(sample, counts)
    gap = centres[first, samples] - centres[second, samples]
    gaps = np.sqrt(np.einsum("mk,mk->m", gap, gap)) - (radii[first] + radii[second])
    smallest = np.repeat(np.minimum.reduceat(gaps, offsets), counts)
    at = np.minimum.reduceat(np.where(gaps == smallest, np.arange(len(gaps)), len(gaps)), offsets)
    return first[at], second[at]
