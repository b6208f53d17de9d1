"""Inverse geometric model along a reference path that a force loop displaces: one batched IK per chunk.

A force controller (eq. 15) moves the tool-centre-point reference T_k of the painting path by a
Cartesian offset Δ_k that changes slowly (an integral of the force error), and tracks the joint
positions ``q_k = IK(T_k + Δ_k)`` at 1 kHz. Solving one pose per period costs a whole batched
IK call each time; here the poses of a chunk of upcoming samples are solved at once around an anchor
offset Δ₀ (the offset when the chunk starts), together with their forward differences along x, y
and z, and each period takes

    q_k ≈ IK(T_k + Δ₀) + G_k·(Δ_k − Δ₀),        G_k = ∂IK/∂p (T_k + Δ₀)     (N_J × 3)

whose error is second order in |Δ_k − Δ₀| (G only along the axes the offset has moved along; a move
along another one starts a new chunk at once). A new chunk starts when the chunk is used up or when
|Δ_k − Δ₀| exceeds ``tolerance``; with the default 0.2 mm the error stays below 5e-7 rad (tested
against the exact IK). Chunks shrink while the offset moves fast (the approach) and grow back while
it holds still (pressing on the wall).

:class:`DisplacedPathBatch` follows several such paths at once, one offset each (the runs of a
painting task that share a path): one stacked lookup per sample for all of them, each path renewing
its own chunks when its own offset asks for it. A path followed alone is a batch of one.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lwrlab.kinematics.swivel_ik import Branch, SwivelIK

FROZEN_AXIS_WEIGHT = 1e12
"""Weight of an axis without a column of G in the test |Δ − Δ₀|² ≤ tolerance²: any move of it starts a
new chunk."""


class DisplacedPathIK:
    """Joint positions of the tool poses ``reference[k]`` shifted by an offset, on one IK branch.

    Parameters
    ----------
    ik : the analytic IK of the robot.
    reference : (N, 4, 4) tool-centre-point poses of the path (base frame, m).
    tcp_in_flange : (4, 4) tool centre point in the flange frame.
    swivel : swivel angle φ (rad), constant along the path.
    branch : IK branch.
    chunk : most samples solved per batched call.
    tolerance : largest |Δ − Δ₀| (m) the linear correction is used for.
    step : forward-difference step of G (m).

    Examples
    --------
    >>> path_ik = DisplacedPathIK(ik, poses, tcp, swivel=-1.6, branch=Branch(1, -1, -1))  # doctest: +SKIP
    >>> q_desired = path_ik(k, np.array([-0.003, 0.0, 0.0]))                              # doctest: +SKIP
    """

    def __init__(
        self,
        ik: SwivelIK,
        reference: np.ndarray,
        tcp_in_flange: np.ndarray,
        swivel: float,
        branch: Branch,
        chunk: int = 2048,
        tolerance: float = 2e-4,
        step: float = 1e-6,
    ) -> None:
        if chunk < 1 or tolerance <= 0 or step <= 0:
            raise ValueError(
                f"chunk ({chunk}), tolerance ({tolerance} m) and step ({step} m) must be positive"
            )
        self.ik, self.swivel, self.branch = ik, float(swivel), branch
        self.flange = np.asarray(reference, dtype=float) @ np.linalg.inv(tcp_in_flange)
        self.max_chunk, self.step, self.tolerance = int(chunk), float(step), float(tolerance)
        self.moving = np.zeros(3, dtype=bool)
        """Axes the offset has moved along so far: the chunks carry G's columns for these only."""
        self.solves = 0
        """Batched IK calls so far."""
        self._anchor = np.zeros(3)  # offset of the last chunk
        self._single: DisplacedPathBatch | None = None

    def __len__(self) -> int:
        return self.flange.shape[0]

    @property
    def weights(self) -> np.ndarray:
        """(3,) weights of |Δ − Δ₀|² in the tolerance test: 1 on a moving axis, huge on a frozen one."""
        return np.where(self.moving, 1.0, FROZEN_AXIS_WEIGHT)

    def solve_chunk(self, k: int, offset: np.ndarray, length: int) -> tuple[np.ndarray, np.ndarray]:
        """IK of up to ``length`` samples from ``k`` at the anchor ``offset`` (3,) m, and its gradient.

        Returns q (L, N_J) rad and G (L, N_J, 3) rad/m (zero columns for the frozen axes).
        """
        if not 0 <= k < len(self):
            raise IndexError(f"sample {k} outside the reference path of {len(self)} poses")
        # an axis the offset has moved along gets its column of G; the others (a force loop on the
        # normal alone leaves two) are held exactly, at no cost, until they move
        self.moving |= offset != self._anchor
        axes = np.flatnonzero(self.moving)
        end = min(k + length, len(self))
        poses = np.repeat(
            self.flange[None, k:end], 1 + axes.size, axis=0
        )  # at Δ₀, then +h along each moving axis
        poses[:, :, :3, 3] += offset
        for row, axis in enumerate(axes, start=1):
            poses[row, :, axis, 3] += self.step
        q = self.ik.solve_branch(poses.reshape(-1, 4, 4), self.swivel, self.branch).q.reshape(
            1 + axes.size, end - k, -1
        )
        gradient = np.zeros((end - k, q.shape[2], 3))
        gradient[:, :, axes] = (np.angle(np.exp(1j * (q[1:] - q[0]))) / self.step).transpose(
            1, 2, 0
        )  # wrapped at ±π
        self._anchor = np.array(offset, dtype=float)
        self.solves += 1
        return q[0], gradient

    def __call__(self, k: int, offset: np.ndarray) -> np.ndarray:
        """(N_J,) joint positions (rad) putting the tool centre point at ``reference[k]`` moved by
        ``offset`` (3,) m."""
        if self._single is None:
            self._single = DisplacedPathBatch([self])
        return self._single(k, np.asarray(offset, dtype=float)[None])[0]


class DisplacedPathBatch:
    """R displaced paths followed in lockstep: ``q_r = IK_r(reference_r[k] + Δ_r)`` for every run r.

    Parameters
    ----------
    paths : one :class:`DisplacedPathIK` per run (its own IK and reference, one tolerance for all),
        each followed by this batch only.

    Every path keeps its chunk in a ring of ``max(chunk)`` samples indexed by ``k mod size``, so the
    chunks of all paths, whatever sample each started at, are read at one index: a view, not a gather.
    """

    def __init__(self, paths: Sequence[DisplacedPathIK]) -> None:
        if not paths:
            raise ValueError("a path batch needs at least one path")
        if len({path.tolerance for path in paths}) > 1:
            tolerances = [path.tolerance for path in paths]
            raise ValueError(f"paths followed together need one tolerance, got {tolerances}")
        self.paths = list(paths)
        n_paths, n_joints = len(paths), paths[0].ik.robot.n_joints
        self._size = max(path.max_chunk for path in paths)
        self._q = np.zeros((self._size, n_paths, n_joints))
        self._gradient = np.zeros((self._size, n_paths, n_joints, 3))
        self._start = np.zeros(n_paths, dtype=int)
        self._end = np.zeros(n_paths, dtype=int)
        self._length = [min(8, path.max_chunk) for path in paths]  # first chunks short: the offset moves
        self._anchor = np.zeros((n_paths, 3))
        self._weights = np.full((n_paths, 3), FROZEN_AXIS_WEIGHT)
        self._tolerance_squared = paths[0].tolerance ** 2
        self._covered = (0, 0)  # samples [first, end) that every current chunk covers

    def _renew(self, r: int, k: int, offset: np.ndarray) -> None:
        """A new chunk for path ``r`` from sample ``k`` at ``offset``: longer once the last one was used
        up, shorter when its offset moved away early."""
        path = self.paths[r]
        j, span = k - self._start[r], self._end[r] - self._start[r]
        self._length[r] = (
            max(8, min(2 * int(j), path.max_chunk))
            if 0 < j < span
            else min(2 * self._length[r], path.max_chunk)
        )
        q, gradient = path.solve_chunk(k, offset, self._length[r])
        ring = np.arange(k, k + len(q)) % self._size
        self._q[ring, r], self._gradient[ring, r] = q, gradient
        self._start[r], self._end[r] = k, k + len(q)
        self._anchor[r], self._weights[r] = offset, path.weights
        self._covered = (int(self._start.max()), int(self._end.min()))

    def __call__(self, k: int, offsets: np.ndarray) -> np.ndarray:
        """(R, N_J) joint positions (rad) of the reference poses ``k`` moved by ``offsets`` (R, 3) m."""
        first, end = self._covered
        if not first <= k < end:
            for r in np.flatnonzero((k < self._start) | (k >= self._end)):
                self._renew(int(r), k, offsets[r])
        shift = offsets - self._anchor
        weighted = shift * self._weights
        # the sum over the paths of w·|Δ − Δ₀|² bounds each one's: one dot product in the common case
        if np.vdot(weighted, shift) > self._tolerance_squared:
            for r in np.flatnonzero((weighted * shift).sum(axis=1) > self._tolerance_squared):
                self._renew(int(r), k, offsets[r])
            shift = offsets - self._anchor
        # q ≈ IK(T_k + Δ₀) + G_k·(Δ_k − Δ₀), second order in |Δ_k − Δ₀|
        i = k % self._size
        return self._q[i] + (self._gradient[i] @ shift[:, :, None])[:, :, 0]
