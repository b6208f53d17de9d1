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
"""

from __future__ import annotations

import numpy as np

from lwrlab.kinematics.swivel_ik import Branch, SwivelIK

FROZEN_AXIS_WEIGHT = 1e12
"""Weight of an axis without a column of G in the test |Δ − Δ₀|² ≤ tolerance²: any move of it starts a new chunk."""


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
        self.max_chunk, self.step = int(chunk), float(step)
        self._tolerance_squared = float(tolerance) ** 2
        self._length = min(8, self.max_chunk)  # first chunk short: the offset usually moves at the start
        self._start, self._end = 0, 0
        self._anchor = np.zeros(3)
        self._moving = np.zeros(3, dtype=bool)
        self._weights = np.full(3, FROZEN_AXIS_WEIGHT)
        self._q = self._gradient = np.empty((0, 7))
        self.solves = 0
        """Batched IK calls so far."""

    def __len__(self) -> int:
        return self.flange.shape[0]

    def _solve(self, k: int, offset: np.ndarray) -> None:
        if not 0 <= k < len(self):
            raise IndexError(f"sample {k} outside the reference path of {len(self)} poses")
        # an axis the offset has moved along gets its column of G; the others (a force loop on the
        # normal alone leaves two) are held exactly, at no cost, until they move
        self._moving |= offset != self._anchor
        self._weights = np.where(self._moving, 1.0, FROZEN_AXIS_WEIGHT)
        axes = np.flatnonzero(self._moving)
        end = min(k + self._length, len(self))
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
        self._q, self._gradient = q[0], gradient
        self._anchor = np.array(offset, dtype=float)
        self._start, self._end = k, end
        self.solves += 1

    def __call__(self, k: int, offset: np.ndarray) -> np.ndarray:
        """(N_J,) joint positions (rad) putting the tool centre point at ``reference[k]`` moved by ``offset`` (3,) m."""
        j = k - self._start
        span = self._end - self._start
        shift = offset - self._anchor
        if 0 <= j < span and (shift * self._weights) @ shift <= self._tolerance_squared:
            return self._q[j] + self._gradient[j] @ shift
        # a new chunk: longer once a chunk is used up, shorter when the offset moved away early
        self._length = (
            max(8, min(2 * j, self.max_chunk)) if 0 < j < span else min(2 * self._length, self.max_chunk)
        )
        self._solve(k, offset)
        return self._q[0].copy()
