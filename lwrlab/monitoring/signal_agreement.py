"""Stretches of a log whose logged velocities contradict its positions: detections there are labelled.

A recorder can keep sending a stale or extrapolated value of one signal while another moves on:
the three real LWR4+ runs end with the positions coming to rest within 0.3 s while the logged
velocities stay near their last value (0.6–1.4 rad/s) and the torques barely change. From positions
and torques alone that is exactly a collision — the arm stopped and no joint torque stopped it — so
the observer raises one, and no threshold that would also catch a real stop of that shape stays
silent. The logged velocities are the only witness against it. Where a log has them,
:func:`disagreeing_samples` finds where they part from the positions' derivative far beyond what
the lag of a velocity filter explains; the monitor warns, naming the stretch
(:class:`SignalDisagreementWarning`), and labels every detection that overlaps it
(``signals_disagree``): a contact that cannot be told from a recording artefact is said to be one,
never silently raised nor silently dropped.
"""

from __future__ import annotations

import numpy as np

from lwrlab.numerics.stretches import true_stretches

SPEED_SHARE = 0.25
"""A sample disagrees where some joint's |logged q̇ − d/dt q| exceeds this share of the joint's
99th-percentile speed: a gross disagreement, not a filter's lag or noise (on the real LWR4+ runs at
most 0.14 anywhere but their final stop, 0.25–0.8 there)."""
EDGE_SHARE = 0.05
"""A disagreeing stretch extends on either side while the difference stays above this share: the
parting grows from nothing."""
MIN_DISAGREEMENT = 0.05
"""rad/s (m/s): a smaller difference never counts, whatever the joint's speed — a joint that
hardly moves, or an arm standing still, has encoder noise in its velocities and no speed to share."""
PAD_S = 0.05
"""Seconds added on each side of a disagreeing stretch (the estimates' filters carry it on)."""


class SignalDisagreementWarning(UserWarning):
    """A log's logged velocities contradict its positions over a stretch."""


def disagreeing_samples(t: np.ndarray, dq_logged: np.ndarray, dq_derived: np.ndarray) -> np.ndarray:
    """(N,) True where the logged velocities ``dq_logged`` part from the positions' derivative
    ``dq_derived`` (both (N, N_J), rad/s).

    Examples
    --------
    >>> t = np.arange(1000) * 5e-3
    >>> derived = np.column_stack([np.sin(t), np.cos(t)])
    >>> logged = derived + 1e-3 * np.random.default_rng(0).normal(size=derived.shape)
    >>> bool(disagreeing_samples(t, logged, derived).any())
    False
    >>> still = np.zeros_like(derived)  # an arm standing still: encoder noise is no disagreement
    >>> bool(disagreeing_samples(t, still + 1e-2 * np.sin(50 * t)[:, None], still).any())
    False
    >>> logged[-20:, 0] = logged[-21, 0]  # a stale velocity while the position comes to rest
    >>> derived[-20:, 0] = 0.0
    >>> flagged = disagreeing_samples(t, logged, derived)
    >>> int(np.flatnonzero(flagged)[0]), bool(flagged[-1])
    (970, True)
    """
    difference = np.abs(np.asarray(dq_logged, dtype=float) - np.asarray(dq_derived, dtype=float))
    speed = np.percentile(np.abs(dq_derived), 99, axis=0)
    core = np.any(difference > np.maximum(SPEED_SHARE * speed, MIN_DISAGREEMENT), axis=1)
    if not core.any():
        return core
    edge = np.maximum(EDGE_SHARE * speed, MIN_DISAGREEMENT * EDGE_SHARE / SPEED_SHARE)
    parting = np.any(difference > edge, axis=1)  # core ⊂ parting
    flagged = np.zeros_like(core)
    for start, stop in zip(*true_stretches(parting), strict=True):
        if core[start:stop].any():
            flagged[start:stop] = True
    period = float((t[-1] - t[0]) / max(len(t) - 1, 1))
    pad = int(np.ceil(PAD_S / period))
    return np.convolve(flagged.astype(float), np.ones(2 * pad + 1), mode="same") > 0


def describe_disagreement(name: str, t: np.ndarray, flagged: np.ndarray) -> str:
    """One line naming where the logged velocities of ``name`` contradict its positions.

    Examples
    --------
    >>> t = np.arange(10) * 0.1
    >>> line = describe_disagreement("run3", t, np.array([0, 0, 0, 0, 0, 0, 0, 1, 1, 1], dtype=bool))
    >>> line.split(": a contact")[0]
    'run3: the logged velocities contradict the positions over 0.3 s (0.7–0.9 s from its start)'
    """
    index = np.flatnonzero(flagged)
    seconds = len(index) * float((t[-1] - t[0]) / max(len(t) - 1, 1))
    first, last = t[index[0]] - t[0], t[index[-1]] - t[0]
    return (
        f"{name}: the logged velocities contradict the positions over {seconds:.2g} s ({first:.3g}–"
        f"{last:.3g} s from its start): a contact detected there may be a recording artefact "
        "(signals_disagree in detections.csv)"
    )
