"""Inertial regressor of any Pinocchio model, one ``pin.computeJointTorqueRegressor`` call per sample.

The engine of trees, prismatic joints and small batches (:data:`lwrlab.dynamics.regressor.SMALL_BATCH`);
the reference the vectorised recursion of :mod:`lwrlab.dynamics.chain_regressor` is tested against.
Pinocchio orders a segment's parameters ``[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]``; the
columns are permuted to the standard order (:data:`lwrlab.model.inertia.PIN_TO_STANDARD`).
"""

from __future__ import annotations

import functools
import threading

import numpy as np
import pinocchio as pin

from lwrlab.model.inertia import PIN_TO_STANDARD

_thread_state = threading.local()


def loop_inertial_regressor(
    model: pin.Model, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    """Inertial regressor by one ``pin.computeJointTorqueRegressor`` call per sample (any model).

    q, dq, ddq: joint positions (rad), velocities (rad/s), accelerations (rad/s²), shape (N, N_V).
    ``out``: an (N, N_V, 10·N_L) array (a view will do) to write into; a new one if None.
    """
    data = model.createData()
    regress = pin.computeJointTorqueRegressor
    n_samples, n_columns = len(q), 10 * (model.njoints - 1)
    # Pinocchio's rows land in a buffer kept between calls (fresh memory costs a page fault per
    # 4 KiB, about as much as the calls themselves for small batches), then one np.take puts the
    # columns in the standard order (indexing the last axis of a 4-D array is 10× slower).
    pinocchio_order = _loop_buffer(n_samples * model.nv * n_columns).reshape(n_samples, model.nv, n_columns)
    for k in range(n_samples):
        pinocchio_order[k] = regress(model, data, q[k], dq[k], ddq[k])
    if out is None:
        return np.take(pinocchio_order, _standard_columns(n_columns // 10), axis=2)
    out[...] = np.take(pinocchio_order, _standard_columns(n_columns // 10), axis=2)
    return out


@functools.cache
def _standard_columns(n_links: int) -> np.ndarray:
    """Columns of Pinocchio's regressor in the standard order: ``W_standard = W_pinocchio[:, columns]``."""
    return (10 * np.arange(n_links)[:, None] + PIN_TO_STANDARD).ravel()


def _loop_buffer(size: int) -> np.ndarray:
    """This thread's scratch of at least ``size`` floats (kept up to 1 MB)."""
    buffer: np.ndarray | None = _thread_state.__dict__.get("loop_buffer")
    if buffer is None or buffer.size < size:
        buffer = np.empty(size)
        if size <= 1 << 17:
            _thread_state.loop_buffer = buffer
    return buffer[:size]
