"""What keeps a robot commanded by joint positions safe: limited commands and the reasons to stop.

A controller that sends joint positions to a robot (a ``ros2_control`` forward position controller)
runs beside it, not inside it: its commands and the robot's states cross a network. Three guards:

- :class:`CommandLimiter`: every command within the description's position range, speed and
  acceleration (:class:`~lwrlab.model.robot.JointLimits`), whatever the law asked for; a command
  that is not finite is refused (the caller stops);
- :class:`StateWatch`: the joint states are fresh (the last one no older than ``max_age_s``) and
  their stamps go forward; otherwise a reason to stop commanding (the robot holds its last command);
- :class:`ForceGuard`: the estimated contact force stays below a limit, and once the roller touched
  the wall it keeps touching it while painting; otherwise a reason to retract along the wall normal.

Each guard says *why* in a sentence, which the run writes into its summary, its metrics and
``/diagnostics``.
"""

from __future__ import annotations

import numpy as np

from lwrlab.model.robot import JointLimits

CLAMP_TOLERANCE = 1e-9
"""rad between a command and its request beyond which the command counts as clamped."""


class CommandLimiter:
    """Joint position commands kept within the joint range, the speed and the acceleration limits.

    Parameters
    ----------
    limits : the robot description's joint limits.
    period : time between two commands (s).
    speed_fraction, acceleration_fraction : share of the description's speed and acceleration limits
        the commands may use (1: all of it).

    The commanded motion is a double integrator following the requests: their own speed, plus a
    catch-up toward the request of at most ``sqrt(2·a·|lag|)`` (so that it stops at a request that
    jumped, without overshoot), the sum within the speed limit and changing by at most
    ``a·period`` per command. A smooth request within the limits passes unchanged.
    """

    def __init__(
        self,
        limits: JointLimits,
        period: float,
        *,
        speed_fraction: float = 1.0,
        acceleration_fraction: float = 1.0,
    ) -> None:
        if period <= 0 or not 0 < speed_fraction <= 1 or not 0 < acceleration_fraction <= 1:
            raise ValueError(
                f"period {period} s must be positive and the fractions "
                f"({speed_fraction}, {acceleration_fraction}) within (0, 1]"
            )
        self.lower = np.asarray(limits.position_lower, dtype=float)
        self.upper = np.asarray(limits.position_upper, dtype=float)
        self.speed = speed_fraction * np.asarray(limits.velocity, dtype=float)
        self.acceleration = acceleration_fraction * np.asarray(limits.acceleration, dtype=float)
        self.period = period
        self.q: np.ndarray | None = None
        self.target = np.zeros_like(self.lower)
        self.velocity = np.zeros_like(self.lower)
        self.clamped = 0
        """Commands changed by a limit so far."""

    def reset(self, q: np.ndarray) -> None:
        """Start at rest at ``q`` (rad): the robot's position when commanding begins."""
        self.q = np.clip(np.asarray(q, dtype=float), self.lower, self.upper)
        self.target = self.q.copy()
        self.velocity = np.zeros_like(self.q)

    def __call__(self, q_desired: np.ndarray) -> np.ndarray:
        """The next command (rad, a new array) toward ``q_desired``; a ValueError when it is not finite."""
        if self.q is None:
            raise RuntimeError("reset the limiter at the robot's position before commanding")
        q_desired = np.asarray(q_desired, dtype=float)
        if not np.all(np.isfinite(q_desired)):
            raise ValueError(f"the controller asked for joint positions that are not finite: {q_desired}")
        dt = self.period
        target = np.clip(q_desired, self.lower, self.upper)
        lag = self.target - self.q  # behind the previous request
        # the fastest catch-up that still stops at the request, braking a·dt per period:
        # v·dt + (v − a·dt)·dt + … ≤ |lag| holds for v ≤ −a·dt + sqrt((a·dt)² + 2·a·|lag|)
        # (a period's margin over the continuous sqrt(2·a·|lag|): no overshoot at the last step)
        margin = self.acceleration * dt
        braking = np.sqrt(margin**2 + 2.0 * self.acceleration * np.abs(lag)) - margin
        catch_up = np.sign(lag) * np.minimum(np.abs(lag) / dt, braking)
        wanted = np.clip((target - self.target) / dt + catch_up, -self.speed, self.speed)
        self.target = target
        step = self.acceleration * dt
        velocity = np.clip(wanted, self.velocity - step, self.velocity + step)
        q = np.clip(self.q + velocity * dt, self.lower, self.upper)
        if np.max(np.abs(q - q_desired)) > CLAMP_TOLERANCE:
            self.clamped += 1
        self.velocity = (q - self.q) / dt
        self.q = q
        return q.copy()

    def arrived(self, q: np.ndarray) -> bool:
        """Whether the last command is at ``q`` (within :data:`CLAMP_TOLERANCE`) and at rest there."""
        return (
            self.q is not None
            and float(np.max(np.abs(self.q - np.clip(q, self.lower, self.upper)))) <= CLAMP_TOLERANCE
            and float(np.max(np.abs(self.velocity))) * self.period <= CLAMP_TOLERANCE
        )


class StateWatch:
    """Whether the joint states still come: the last one's age and the order of their stamps.

    Parameters
    ----------
    max_age_s : the oldest the last joint state may be when a command is due (s).
    """

    def __init__(self, max_age_s: float) -> None:
        if max_age_s <= 0:
            raise ValueError(f"the joint states' largest age must be positive, got {max_age_s} s")
        self.max_age_s = max_age_s
        self.last_received_s = float("nan")
        self.last_stamp_s = float("-inf")

    def received(self, stamp_s: float, now_s: float) -> str | None:
        """Note a state stamped ``stamp_s`` received at ``now_s`` (monotonic, s); a reason to stop
        when its stamp goes back."""
        if stamp_s <= self.last_stamp_s:
            return (
                f"joint state stamp went back ({stamp_s:.6f} s after {self.last_stamp_s:.6f} s): "
                "the robot's driver restarted or two robots publish"
            )
        self.last_stamp_s, self.last_received_s = stamp_s, now_s
        return None

    def stale(self, now_s: float) -> str | None:
        """A reason to stop when the last state is older than ``max_age_s`` at ``now_s`` (monotonic, s)."""
        age = now_s - self.last_received_s
        if age > self.max_age_s:
            return (
                f"joint states stalled: the last one is {1e3 * age:.1f} ms old "
                f"(limit {1e3 * self.max_age_s:g} ms); stopped commanding, the robot holds its last command"
            )
        return None


class ForceGuard:
    """The estimated contact force within its limit, and the contact kept once made.

    Parameters
    ----------
    normal : (3,) unit normal of the wall, towards the robot (base axes).
    limit_n : the largest force (N, its magnitude: pressing on the wall or a collision) before retracting.
    contact_n : the pressing force (N) from which the roller counts as touching.
    lost_after_s : how long (s) the force may stay below ``contact_n`` once touched, while painting.
    period : time between two checks (s).
    """

    def __init__(
        self, normal: np.ndarray, *, limit_n: float, contact_n: float, lost_after_s: float, period: float
    ) -> None:
        if not 0 < contact_n < limit_n:
            raise ValueError(f"need 0 < contact force ({contact_n} N) < force limit ({limit_n} N)")
        self.normal = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
        self.limit_n, self.contact_n = limit_n, contact_n
        self.lost_after_s, self.period = lost_after_s, period
        self.touched = False
        self._below_s = 0.0

    def pressing(self, force: np.ndarray) -> float:
        """The force pressing on the wall (N, positive into it) of ``force`` exerted on the environment."""
        return -float(np.dot(self.normal, force[:3]))

    def check(self, force: np.ndarray, painting: bool) -> str | None:
        """A reason to retract for the estimated ``force`` (N, on the environment, base axes), or None.

        ``painting``: whether the path is being painted (the contact is expected); before it, while
        the force builds up, only the limit applies.
        """
        pressing, magnitude = self.pressing(force), float(np.linalg.norm(force[:3]))
        if magnitude > self.limit_n:  # whatever its direction: pressing, or a collision
            return (
                f"force estimate {magnitude:.1f} N beyond the {self.limit_n:g} N limit: "
                "retracted along the wall normal"
            )
        if pressing >= self.contact_n:
            self.touched, self._below_s = True, 0.0
        elif self.touched and painting:
            self._below_s += self.period
            if self._below_s >= self.lost_after_s:
                return (
                    f"contact lost: force estimate below {self.contact_n:g} N for "
                    f"{1e3 * self._below_s:.0f} ms while painting: retracted along the wall normal"
                )
        return None


__all__ = ["CommandLimiter", "ForceGuard", "StateWatch"]
