"""The painting controller's sample path: a joint state in, a joint position command out.

:class:`PaintingLoop` is driven by the robot's joint states, one call of :meth:`PaintingLoop.on_state`
each, as they arrive. Every state goes through eq. (14)'s estimator
(:class:`~lwrlab.control.force_estimation.ExternalForceEstimator`, the one ``task=painting`` uses);
what is commanded depends on the phase:

0. ``waiting``: the first states start the estimator; :meth:`PaintingLoop.prepare` then plans the
   move to the start and resets the controller there, off the sample path;
1. ``moving``: from where the robot stands to ``clearance`` off the wall in front of the path's start
   (a joint-space quintic within a share of the speed and acceleration limits), then straight along
   the wall normal to the start (``standoff`` off the wall), at ``approach_speed``;
2. ``painting``: the ``PaintingController`` plugin along the painting path (its approach while the
   force builds up, then the path), its joint reference commanded, one path sample per state;
3. ``retracting``: straight along the wall normal, ``retract_distance`` at ``retract_speed``, when the
   path is painted, the force estimate passes its limit or the contact is lost;
4. ``stopped``: nothing commanded any more (the robot holds its last command, as a forward position
   controller does): after a retraction, a stalled or stamp-reversed state stream, or a command
   that is not finite.

Every command passes the :class:`~lwrlab.control.command_safety.CommandLimiter`; every stop leaves
its reason (:attr:`PaintingLoop.reason`). The loop records each state's sample in preallocated
arrays (no allocation grows on the sample path); the task scores them after the run.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from lwrlab.control.command_safety import CommandLimiter, ForceGuard, StateWatch
from lwrlab.control.contact_loop import PaintingController
from lwrlab.control.force_estimation import ExternalForceEstimator
from lwrlab.control.joint_pd import ControlSetup

PHASES = ("waiting", "moving", "painting", "retracting", "stopped")
"""The loop's phases, in order; their index is the ``phase`` recorded per sample."""
QUINTIC_PEAK_SPEED = 1.875
"""Peak speed of the quintic 10s³ − 15s⁴ + 6s⁵ over its mean speed."""
QUINTIC_PEAK_ACCELERATION = 5.7735
"""Peak acceleration of that quintic over distance / duration²."""


@dataclass(frozen=True, kw_only=True)
class SafetySettings:
    """The live painting's guards (conf/task/live_painting.yaml ``safety``)."""

    max_state_age_s: float
    """s, the oldest the last joint state may be before commanding stops."""
    force_limit_n: float
    """N, pressing force estimate beyond which the roller retracts."""
    contact_n: float
    """N, pressing force from which the roller counts as touching the wall."""
    contact_lost_s: float
    """s below ``contact_n`` while painting, once touched, that count as a lost contact."""
    speed_fraction: float
    """Share of the description's joint speed limits a command may use."""
    acceleration_fraction: float
    """Share of the description's joint acceleration limits a command may use."""
    retract_distance: float
    """m along the wall normal a retraction moves."""
    retract_speed: float
    """m/s of a retraction (and of the approach along the normal)."""
    clearance: float
    """m off the wall where the move to the start ends, before the straight approach."""
    move_speed_fraction: float
    """Share of the joint speed and acceleration limits of the move to the start."""


@dataclass
class Records:
    """What the loop saw and did, one row per joint state (preallocated; ``n`` rows filled)."""

    stamp_ns: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    wrench: np.ndarray
    command: np.ndarray
    commanded_position: np.ndarray
    phase: np.ndarray
    path_index: np.ndarray
    """Painting-path sample commanded (−1 outside the painting phase)."""
    latency_ns: np.ndarray
    """State received → command published (ns; 0 when nothing was commanded)."""
    compute_ns: np.ndarray
    """The loop's own time on the state (ns): estimate, law, guards, limits, publication."""
    n: int = 0

    @classmethod
    def empty(cls, capacity: int, n_joints: int) -> Records:
        nan = np.full
        return cls(
            np.zeros(capacity, np.int64),
            nan((capacity, n_joints), np.nan),
            nan((capacity, n_joints), np.nan),
            nan((capacity, 6), np.nan),
            nan((capacity, n_joints), np.nan),
            nan((capacity, 3), np.nan),
            np.zeros(capacity, np.int8),
            np.full(capacity, -1, np.int64),
            np.zeros(capacity, np.int64),
            np.zeros(capacity, np.int64),
        )


class PaintingLoop:
    """The painting controller driven by joint states (see the module).

    Parameters
    ----------
    setup : the controller's model, IK and path settings.
    controller : the ``PaintingController`` plugin (force fed back: its estimate).
    estimator : eq. (14) on the controller's model.
    reference : (N, 4, 4) tool poses, one per state: the approach while the force builds up, then the path.
    painting : (N,) True on the path's samples (the contact is expected).
    start : (4, 4) tool pose the painting starts from (off the wall by the standoff).
    normal : (3,) the wall's normal towards the robot.
    safety : the guards' settings.
    publish : ``publish(command, wrench, stamp_ns)`` sends a command (rad) and the force estimate.
    capacity : most joint states recorded.
    """

    def __init__(
        self,
        *,
        setup: ControlSetup,
        controller: PaintingController,
        estimator: ExternalForceEstimator,
        reference: np.ndarray,
        painting: np.ndarray,
        start: np.ndarray,
        normal: np.ndarray,
        safety: SafetySettings,
        publish: Callable[[np.ndarray, np.ndarray, int], None],
        capacity: int,
    ) -> None:
        self.setup, self.controller, self.estimator = setup, controller, estimator
        self.reference, self.painting, self.start = reference, np.asarray(painting, bool), start
        self.normal = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
        self.safety, self.publish = safety, publish
        limits = setup.robot.limits
        self.limiter = CommandLimiter(
            limits,
            setup.period,
            speed_fraction=safety.speed_fraction,
            acceleration_fraction=safety.acceleration_fraction,
        )
        self.watch = StateWatch(safety.max_state_age_s)
        self.guard = ForceGuard(
            self.normal,
            limit_n=safety.force_limit_n,
            contact_n=safety.contact_n,
            lost_after_s=safety.contact_lost_s,
            period=setup.period,
        )
        self.records = Records.empty(capacity, setup.robot.n_joints)
        self.phase = 0
        self.reason: str | None = None
        """Why the loop stopped commanding (None while it commands)."""
        self.retract_reason: str | None = None
        self._queue = np.zeros((0, setup.robot.n_joints))
        self._index = 0
        self._k = 0
        self._lock = threading.Lock()
        self._fk_data = estimator.model.createData()
        self._no_force = np.zeros(3)
        self._last_check_s = float("-inf")
        self.superseded = 0
        """States not answered by a command: a newer one had already come (see :meth:`on_state`)."""

    # the sample path ----------------------------------------------------------------------------

    def on_state(
        self, stamp_ns: int, q: np.ndarray, tau: np.ndarray, received_s: float, newer: int = 0
    ) -> None:
        """One joint state (stamp ns, positions rad, link-side torques N·m, receipt time monotonic s).

        ``newer``: states already received after this one. The estimate and the guards see every
        state (the estimate's filters run at the states' rate); the motion (the move, the path, the
        force loop) steps, and a command goes out, on the newest only: a controller that fell behind
        answers where the robot is now instead of with a burst of stale commands (which a robot
        stepping on each command would keep behind for ever), and resumes its motion where its last
        command left it, within its limits, instead of jumping ahead.
        """
        entered = time.perf_counter_ns()
        with self._lock:
            self._on_state(stamp_ns, q, tau, received_s, newer == 0)
            self.records.compute_ns[self.records.n - 1] = time.perf_counter_ns() - entered

    def _on_state(
        self, stamp_ns: int, q: np.ndarray, tau: np.ndarray, received_s: float, answer: bool
    ) -> None:
        records, row = self.records, self.records.n
        if row >= records.stamp_ns.size:
            self._stop("the run outgrew its record (the planned motion and 30 s more)")
            return
        records.n = row + 1
        records.stamp_ns[row], records.q[row], records.tau[row] = stamp_ns, q, tau
        reason = self.watch.received(stamp_ns * 1e-9, received_s)
        if reason is not None and self.phase != PHASES.index("stopped"):
            self._stop(reason)
        if row == 0:
            self.estimator.reset(q)
        state = self.estimator.update(q, tau)
        records.wrench[row] = state.wrench
        records.phase[row] = self.phase
        if self.phase in (0, 4):  # nothing to command yet (see prepare), or no more
            return
        if not answer:  # a newer state waits: the guards see this one, the motion steps on the newest
            self.superseded += 1
            self._guard_only(state.wrench)
            return
        if self.phase == 2:
            k = self._k
            decision = self.controller.command(k, state, self._no_force)
            target = decision.q_desired
            records.commanded_position[row], records.path_index[row] = decision.commanded_position, k
            self._k = k + 1
            reason = self.guard.check(state.wrench, bool(self.painting[k]))
            if reason is None and self._k == self.reference.shape[0]:
                reason = "painted the whole path: retracted along the wall normal"
            if reason is not None:
                self._retract(reason)
        if self.phase == 1 and self._stopped_on_the_way(state.wrench):
            return
        moving = self.phase in (1, 3)
        if moving:  # the queue's motion, then its end until the limited commands arrive there
            target = self._queue[min(self._index, self._queue.shape[0] - 1)]
            self._index += 1
        try:
            command = self.limiter(target)
        except ValueError as error:
            self._stop(f"{error}: stopped commanding")
            return
        self.publish(command, state.wrench, stamp_ns)
        records.command[row] = command
        if moving and self._index >= self._queue.shape[0] and self.limiter.arrived(target):
            if self.phase == 1:
                self.phase, self._k = 2, 0
            else:
                self._stop(self.retract_reason or "retracted")

    def _guard_only(self, wrench: np.ndarray) -> None:
        """The force guards on a state nothing is commanded for: a retraction or a stop starts with
        the next state answered."""
        if self.phase == 2:
            reason = self.guard.check(wrench, bool(self.painting[self._k]))  # painting: k < the path's end
            if reason is not None:
                self._retract(reason)
        elif self.phase == 1:
            self._stopped_on_the_way(wrench)

    def _stopped_on_the_way(self, wrench: np.ndarray) -> bool:
        """On the way to the start only the force limit (a collision) applies: whether it stopped."""
        reason = self.guard.check(wrench, False)
        if reason is not None:
            self._stop(reason.replace("retracted along the wall normal", "stopped on the way to the start"))
        return reason is not None

    def prepare(self) -> None:
        """Plan the move from the robot's position (its last state) to the path's start and reset the
        controller there; then commanding begins. Called once, off the sample path (planning the
        path's IK takes longer than a period), after the first state."""
        if self.records.n == 0:
            raise RuntimeError("prepare the painting once a joint state has come")
        q = self.records.q[self.records.n - 1].copy()
        queue = self._move_to_start(q)
        self.controller.reset(self.setup, queue[-1], self.reference)
        with self._lock:
            if self.phase == 0:
                q = self.records.q[self.records.n - 1].copy()  # where it stands now
                self.limiter.reset(q)
                self._queue, self._index, self.phase = queue, 0, 1

    def check_stale(self, now_s: float) -> None:
        """Stop commanding when the last joint state is too old at ``now_s`` (monotonic s); the
        watchdog calls it between states. A check coming late (the watchdog's process was not
        scheduled) is skipped: states may be waiting to be taken, which the next check sees."""
        late = now_s - self._last_check_s > 0.5 * self.safety.max_state_age_s
        self._last_check_s = now_s
        if late:  # the watchdog itself was held up: the states may wait to be taken, look again soon
            return
        if self.phase in (1, 2, 3):
            reason = self.watch.stale(now_s)
            if reason is not None:
                with self._lock:
                    if self.phase != 4:
                        self._stop(reason)

    def stop(self, reason: str) -> None:
        """Stop commanding now (a signal, the run's end) with ``reason``."""
        with self._lock:
            if self.phase != 4:
                self._stop(reason)

    @property
    def stopped(self) -> bool:
        """Whether the loop has stopped commanding."""
        return self.phase == 4

    @property
    def progress(self) -> float:
        """Share of the path commanded (0…1)."""
        return self._k / self.reference.shape[0]

    # motions --------------------------------------------------------------------------------------

    def _stop(self, reason: str) -> None:
        self.phase, self.reason = 4, reason

    def _line(self, pose: np.ndarray, distance: float) -> np.ndarray:
        """Joint positions moving the tool from ``pose`` along the normal by ``distance`` (m)."""
        count = max(round(abs(distance) / self.safety.retract_speed / self.setup.period), 1)
        poses = np.repeat(pose[None], count, axis=0)
        poses[:, :3, 3] += np.outer(np.linspace(0.0, distance, count + 1)[1:], self.normal)
        setup = self.setup
        return setup.ik.solve_branch(poses @ setup.flange_in_tcp, setup.swivel, setup.branch).q

    def _move_to_start(self, q: np.ndarray) -> np.ndarray:
        """From ``q`` to ``clearance`` before the start (joint quintic), then along the normal to it."""
        clear = self.start.copy()
        clear[:3, 3] += self.safety.clearance * self.normal
        q_clear = self.setup.joint_reference(clear)
        limits, share = self.setup.robot.limits, self.safety.move_speed_fraction
        distance = np.abs(q_clear - q)
        duration = max(
            float(np.max(QUINTIC_PEAK_SPEED * distance / (share * limits.velocity))),
            float(np.sqrt(np.max(QUINTIC_PEAK_ACCELERATION * distance / (share * limits.acceleration)))),
            self.setup.period,
        )
        s = np.linspace(0.0, 1.0, max(round(duration / self.setup.period), 1) + 1)[1:, None]
        quintic = q + (q_clear - q) * (10 * s**3 - 15 * s**4 + 6 * s**5)
        return np.concatenate([quintic, self._line(clear, -self.safety.clearance)])

    def _retract(self, reason: str) -> None:
        """Retract from the last command along the normal; ``reason`` is the stop's once retracted."""
        assert self.limiter.q is not None
        model, data = self.estimator.model, self._fk_data
        pin.framesForwardKinematics(model, data, self.limiter.q)
        pose = data.oMf[self.estimator.frame_id].homogeneous
        self.retract_reason = reason
        self._queue, self._index, self.phase = self._line(pose, self.safety.retract_distance), 0, 3


__all__ = ["PHASES", "PaintingLoop", "Records", "SafetySettings"]
