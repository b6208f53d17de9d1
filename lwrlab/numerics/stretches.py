"""The stretches of consecutive True samples of a boolean mask.

Contacts above a threshold, a true contact's time above it, a log's samples whose signals disagree
and a motion's rests are all such stretches.
"""

from __future__ import annotations

import numpy as np


def true_stretches(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Starts and (exclusive) ends of the stretches of consecutive True values of ``mask`` (N,).

    Examples
    --------
    >>> true_stretches(np.array([False, True, True, False, True]))
    (array([1, 4]), array([3, 5]))
    """
    padded = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]]).astype(np.int8)
    edges = np.diff(padded)
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
