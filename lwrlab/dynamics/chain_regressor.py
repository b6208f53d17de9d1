"""Inertial regressor of a serial revolute chain by a Newton–Euler recursion vectorised over the samples.

A forward recursion over the joints, done for all samples at once, gives each segment's angular
velocity ω, angular acceleration ω̇ and the acceleration a of its frame origin (gravity enters as a
base acceleration −g), in the segment's frame. The segment's wrench about its origin is linear in
its 10 parameters, ``[n; f] = Y_j·φ_j`` (:mod:`lwrlab.dynamics.segment_wrench`), and joint k ≤ j
feels ``τ_k = u_kjᵀ·Y_j·φ_j``, with ``u_kj`` the unit twist of joint k seen from segment j's origin,
carried forward along the recursion: there is no backward pass.

How it is laid out, and why (each point was measured with ``benchmarks/regressor.py``): a numpy
call costs one to a few microseconds whatever its size, numpy's batched products of tiny matrices
are slow, and fresh memory costs a page fault per 4 KiB, so

* the samples are the *last* axis of every working array: every operation is a long contiguous loop;
* samples go through in chunks of :data:`CHUNK_SAMPLES`, in a workspace kept between calls, whose
  views for each step are made once per chunk size;
* each joint turns about the z axis of its "axis frame" (the joint frame itself in DH models,
  :class:`~lwrlab.dynamics.serial_chain.SerialChain`), and everything constant is one BLAS product
  with a precomputed matrix: the state's and the twists' transport to the next frame before the
  joint turns, and the segment's wrench regressor from its state
  (:data:`~lwrlab.dynamics.segment_wrench.ENTRY_MAP`, which also takes the state from the axis frame
  to the joint frame where the parameters are expressed);
* a segment's frame is one array of rows: the unit twists of the joints before it right before its
  state (ω, ω̇, a, vec(ωωᵀ)), so that one ``np.einsum`` with the 2×2 block of Rz(q)ᵀ per sample
  turns them all (twice as fast as three products with cos q and sin q);
* the torques of joints 0…j due to segment j are the twists dotted with the segment's wrench
  regressor: two ``np.einsum`` calls, into a block laid out [column, joint, sample], which is
  written to the output [sample, joint, column] while it is in the cache.

The products with constant matrices go through BLAS, whose kernels depend on the batch's size: a
sample's regressor depends on the batch around it at the level of round-off (~1e-16 relative).
"""

from __future__ import annotations

import contextlib
import math
import threading
from typing import NamedTuple

import numpy as np

from lwrlab.dynamics.segment_wrench import ENTRY_MAP, STATE, wrench_blocks
from lwrlab.dynamics.serial_chain import SerialChain
from lwrlab.numerics.threads import dense_algebra

CHUNK_SAMPLES = 1000
"""Samples per chunk of the vectorised recursion (a few MB of working arrays).

Smaller chunks cost more numpy calls per sample; larger ones no longer fit the cache.
"""

THREADED_CHUNK = 256
"""From this many samples a chunk's products run under :func:`~lwrlab.numerics.threads.dense_algebra`
(one BLAS thread, ~15 µs to enter). OpenBLAS splits an m·n·k product over threads from 4·65 536 on:
the (42 × 18)·(18 × c) product of the wrench regressor from c = 347 samples, and threads that wait
for a busy core stall the call (20× slower measured on a loaded 2-core machine)."""

_OWN_TWIST = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])[:, None]
"""A joint's unit twist (ω; v) in its own axis frame: it turns about z through the origin."""
_ENTRIES = ENTRY_MAP.shape[0]


class _Step(NamedTuple):
    """Views of the workspace that step j of the recursion works on, for chunks of c samples."""

    parent_state: np.ndarray
    """(18, c) state (ω, ω̇, a, vec(ωωᵀ)) of segment j−1 in its axis frame (unused for j = 0)."""
    parent_twists: np.ndarray
    """(j, 6, c) unit twists (ω; v) of joints 0…j−1 seen from axis frame j−1."""
    unturned_state: np.ndarray
    """(9, c) ω, ω̇, a of segment j before its joint turns and moves (in the workspace's "unturned")."""
    unturned_twists: np.ndarray
    """(j, 6, c) the twists of joints 0…j−1 before joint j turns."""
    unturned: tuple[np.ndarray, np.ndarray]
    """The x, y (2·j + 3, 2, c) and z (2·j + 3, c) components of those twists' vectors and ω, ω̇, a."""
    turned: tuple[np.ndarray, np.ndarray]
    """The same components in frame j, where the state and twists of segment j are kept."""
    state: np.ndarray
    """(18, c) state of segment j in its axis frame."""
    omega_yx: np.ndarray
    """(2, c) ω_y, ω_x of segment j."""
    omega_dot_xy: np.ndarray
    """(2, c) ω̇_x, ω̇_y of segment j."""
    z_rows: np.ndarray
    """(2, c) ω_z, ω̇_z of segment j."""
    coupling: np.ndarray
    """(2, c) scratch for the coupling term."""
    outer: tuple[np.ndarray, np.ndarray, np.ndarray]
    """ω as (3, 1, c) and (1, 3, c), and the (3, 3, c) rows of ωωᵀ in the state."""
    joint_twists: np.ndarray
    """(j + 1, 6, c) unit twists of joints 0…j seen from axis frame j (a reversed view)."""
    joint_vectors: np.ndarray
    """(2·j + 2, 3, c) the same as vectors, in memory order."""
    seen_vectors: np.ndarray
    """(2·j + 2, 3, c) those vectors in joint-frame coordinates (joints that do not turn about z)."""
    seen_twists: np.ndarray
    """(j + 1, 6, c) a reversed view of them as twists."""
    rows: np.ndarray
    """(10, j + 1, c) torques of joints 0…j due to the parameters of segment j."""


class _Workspace:
    """The recursion's arrays for an N_J-joint chain and chunks of up to ``capacity`` samples.

    It is kept between calls (one per thread, see :func:`_workspace`): fresh memory costs a page
    fault per 4 KiB on first touch, which costs more than the arithmetic done on it. Each array is a
    flat buffer viewed for the chunk at hand, so that it is contiguous whatever the chunk's size,
    and the views of each step are made once per chunk size.

    A segment's frame (``frames``) holds, for c samples, in rows ``[6·(N_J−1−k), 6·(N_J−k))`` the
    unit twist of joint k, then from row ``6·N_J`` the segment's state (:data:`STATE`): the twists
    of joints 0…j−1 lie right before the state, so that one set of calls turns them all.
    """

    def __init__(self, n: int, capacity: int) -> None:
        self.n, self.capacity = n, capacity
        self._buffers = {
            name: np.empty(capacity * math.prod(shape)) for name, shape in self._shapes(1).items()
        }
        self._views: dict[int, tuple[dict[str, np.ndarray], list[_Step]]] = {}

    def _shapes(self, c: int) -> dict[str, tuple[int, ...]]:
        n = self.n
        return {
            "frames": (2, 6 * n + len(STATE), c),  # a segment's frame and the next one's
            "unturned": (6 * n + 9, c),  # the twists and ω, ω̇, a of a frame before its joint turns
            "seen": (2 * n, 3, c),  # twists in joint-frame coordinates
            "coupling": (2, c),
            "entries": (_ENTRIES, c),  # a segment's wrench regressor (segment_wrench)
            "rows": (10, n, c),  # a segment's columns of the chunk's regressor, [column, joint, sample]
            "turns": (n, 2, 2, c),  # per joint Rz(q)ᵀ's upper left block [[cos, sin], [−sin, cos]]
            "motion": (2, n, 2, c),  # per joint (q̇, −q̇), (q̇, q̈)
        }

    def views(self, c: int) -> tuple[dict[str, np.ndarray], list[_Step]]:
        """The arrays for a chunk of c ≤ capacity samples, and the views of each step; contents undefined."""
        if c not in self._views:
            if len(self._views) >= 4:
                self._views.pop(next(iter(self._views)))
            arrays = {
                name: self._buffers[name][: math.prod(shape)].reshape(shape)
                for name, shape in self._shapes(c).items()
            }
            arrays["first_moment"], arrays["inertia"] = wrench_blocks(arrays["entries"])
            self._views[c] = arrays, [self._step(arrays, j) for j in range(self.n)]
        return self._views[c]

    def _step(self, arrays: dict[str, np.ndarray], j: int) -> _Step:
        n, c = self.n, arrays["entries"].shape[1]
        state = 6 * n
        child, parent, unturned = arrays["frames"][j % 2], arrays["frames"][(j + 1) % 2], arrays["unturned"]
        turned = child[state - 6 * j : state + 9].reshape(2 * j + 3, 3, c)
        before = unturned[state - 6 * j : state + 9].reshape(2 * j + 3, 3, c)
        omega = child[state : state + 3]
        joint_vectors = child[state - 6 * j - 6 : state].reshape(2 * j + 2, 3, c)
        seen_vectors = arrays["seen"][: 2 * j + 2]
        return _Step(
            parent_state=parent[state:],
            parent_twists=parent[state - 6 * j : state].reshape(j, 6, c),
            unturned_state=unturned[state:],
            unturned_twists=unturned[state - 6 * j : state].reshape(j, 6, c),
            unturned=(before[:, :2], before[:, 2]),
            turned=(turned[:, :2], turned[:, 2]),
            state=child[state:],
            omega_yx=omega[1::-1],
            omega_dot_xy=child[state + 3 : state + 5],
            z_rows=child[state + 2 : state + 6 : 3],
            coupling=arrays["coupling"],
            outer=(omega[:, None], omega[None], child[state + 9 : state + 18].reshape(3, 3, c)),
            joint_twists=joint_vectors.reshape(j + 1, 6, c)[::-1],
            joint_vectors=joint_vectors,
            seen_vectors=seen_vectors,
            seen_twists=seen_vectors.reshape(j + 1, 6, c)[::-1],
            rows=arrays["rows"][:, : j + 1],
        )


_thread_state = threading.local()


def _workspace(n: int) -> _Workspace:
    """This thread's workspace for N_J-joint chains (one per thread: numpy releases the GIL)."""
    spaces = _thread_state.__dict__.setdefault("workspaces", {})
    if n not in spaces or spaces[n].capacity <= CHUNK_SAMPLES:  # CHUNK_SAMPLES changed since
        if len(spaces) >= 4:  # a few MB each: keep those of the robots in use
            spaces.pop(next(iter(spaces)))
        spaces[n] = _Workspace(n, CHUNK_SAMPLES + 1)
    workspace: _Workspace = spaces[n]
    return workspace


def _joint_motion(q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, arrays: dict[str, np.ndarray]) -> None:
    """Per joint, samples last: Rz(q)ᵀ's upper left block, (q̇, −q̇) and (q̇, q̈) into ``arrays``.

    cos and sin come from ``t = tan(q/2)``: ``cos = 2 / (1 + t²) − 1``, ``sin = t·2 / (1 + t²)``. numpy
    evaluates tan with SIMD instructions but, for accuracy, not float64 sin and cos: one tan and a
    few products are several times faster than sin and cos, within a few 1e-16.
    """
    turns, (rates, z_rates) = arrays["turns"], arrays["motion"]
    t, scale = turns[:, 0, 1], turns[:, 1, 0]
    np.multiply(q.T, 0.5, out=t)
    np.tan(t, out=t)
    np.multiply(t, t, out=scale)
    scale += 1.0
    np.divide(2.0, scale, out=scale)  # 2 / (1 + t²)
    np.subtract(scale, 1.0, out=turns[:, 0, 0])  # cos = (1 − t²) / (1 + t²)
    turns[:, 1, 1] = turns[:, 0, 0]
    t *= scale  # sin
    np.negative(t, out=scale)
    rates[:, 0] = z_rates[:, 0] = dq.T
    np.negative(dq.T, out=rates[:, 1])
    z_rates[:, 1] = ddq.T


def _segment_step(chain: SerialChain, j: int, step: _Step, arrays: dict[str, np.ndarray]) -> None:
    """Step j of the Newton–Euler recursion, then the torques due to segment j into ``step.rows``.

    ``ω_j = Rᵀω + q̇·z``, ``ω̇_j = Rᵀω̇ + q̈·z + (Rᵀω) × q̇·z``, ``a_j = Rᵀ(a + ω̇ × t + ω × (ω × t))``
    with ``R = E_j·Rz(q_j)``, t the lever arm and z = e_z the joint axis; a twist moves like a
    velocity, ``ω ← Rᵀω``, ``v ← Rᵀ(v + ω × t)``, and joint j's own is (e_z; 0). Joint k feels
    ``τ_k = u_k·(Y_j·φ_j)``, with u_k its unit twist and Y_j the segment's wrench regressor.
    """
    if j == 0:
        step.unturned_state[...] = chain.base_state[:, None]
    else:  # the constant parts: one product for the state, one for the twists
        np.matmul(chain.state_maps[j], step.parent_state, out=step.unturned_state)
        np.matmul(chain.twist_maps[j], step.parent_twists, out=step.unturned_twists)
    # v ← Rz(q)ᵀ·v for the twists and ω, ω̇, a: (x, y) ← (cos·x + sin·y, cos·y − sin·x), z unchanged
    np.einsum("vsc,tsc->vtc", step.unturned[0], arrays["turns"][j], out=step.turned[0])
    np.copyto(step.turned[1], step.unturned[1])
    # (Rᵀω) × q̇·e_z = q̇·(ω_y, −ω_x, 0), then ω_z += q̇, ω̇_z += q̈
    np.multiply(step.omega_yx, arrays["motion"][0, j], out=step.coupling)
    np.add(step.omega_dot_xy, step.coupling, out=step.omega_dot_xy)
    np.add(step.z_rows, arrays["motion"][1, j], out=step.z_rows)
    np.multiply(*step.outer)
    np.matmul(chain.entry_maps[j], step.state[3:], out=arrays["entries"])
    twists = step.joint_twists
    if chain.turns_axis[j]:  # to joint-frame coordinates, where φ_j and its wrench regressor are expressed
        np.matmul(chain.axis_frames[j], step.joint_vectors, out=step.seen_vectors)
        twists = step.seen_twists
    np.einsum("krc,rpc->pkc", twists, arrays["first_moment"], out=step.rows[:4])
    np.einsum("krc,rpc->pkc", twists[:, :3], arrays["inertia"], out=step.rows[4:])


def _chunk_regressor(
    chain: SerialChain, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, out: np.ndarray, work: _Workspace
) -> None:
    """Write the inertial regressor of c samples (q, dq, ddq (c, N_J)) into ``out`` (m ≤ c, N_J, 10·N_J).

    The first m samples go into ``out`` (the others pad the last chunk of a call); only the blocks
    that can be non-zero are written (segment j on joints k ≤ j).
    """
    c, n = q.shape
    arrays, steps = work.views(c)
    _joint_motion(q, dq, ddq, arrays)
    arrays["frames"][:, : 6 * n].reshape(2, n, 6, c)[...] = _OWN_TWIST  # every joint's own, in place
    m = len(out)
    for j, step in enumerate(steps):
        _segment_step(chain, j, step, arrays)
        # [column, joint, sample] → [sample, joint, column], while the block is in the cache
        out[:, : j + 1, 10 * j : 10 * j + 10] = step.rows[:, :, :m].transpose(2, 1, 0)


def _chunk_size(n_samples: int) -> int:
    """Near-equal chunks of at most about :data:`CHUNK_SAMPLES` samples, never a multiple of 512.

    Not a multiple of 512: rows of the workspace 4 KiB apart alias in the cache and slow the
    transpositions.
    """
    count = -(-n_samples // CHUNK_SAMPLES)
    size = max(1, -(-n_samples // max(count, 1)))
    return size + 1 if size % 512 == 0 else size


def fill_chain_regressor(
    chain: SerialChain, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, out: np.ndarray
) -> None:
    """The inertial regressor of a serial revolute chain into ``out`` (N, N_J, 10·N_J), a view will do.

    Only the blocks that can be non-zero are written (segment j on joints k ≤ j): ``out`` must hold
    zeros elsewhere. It is computed chunk by chunk (:func:`_chunk_regressor`), all of one size: the
    last one is padded with zero states, so the workspace keeps its layout.
    """
    if not q.shape == dq.shape == ddq.shape:
        raise ValueError(f"q, dq and ddq must have one shape, got {q.shape}, {dq.shape} and {ddq.shape}")
    n_samples, n = q.shape
    size = _chunk_size(n_samples)
    work = _workspace(n)
    with dense_algebra() if size >= THREADED_CHUNK else contextlib.nullcontext():
        for start in range(0, n_samples, size):
            stop = min(start + size, n_samples)
            states = [x[start:stop] for x in (q, dq, ddq)]
            if stop - start < size:
                states = [np.concatenate([x, np.zeros((size - (stop - start), n))]) for x in states]
            _chunk_regressor(chain, states[0], states[1], states[2], out[start:stop], work)


def chain_inertial_regressor(
    chain: SerialChain, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> np.ndarray:
    """Inertial regressor of a serial revolute chain, shape (N, N_J, 10·N_J), columns in standard order.

    q, dq, ddq: joint positions (rad), velocities (rad/s), accelerations (rad/s²), shape (N, N_J).
    """
    n_samples, n = q.shape
    out = np.zeros((n_samples, n, 10 * n))
    fill_chain_regressor(chain, q, dq, ddq, out)
    return out
