"""Joint trajectories: the value object, and the protocol that motion plugins implement."""

from lwrlab.trajectory.core import LimitViolation, MotionSource, Trajectory, check_limits

__all__ = ["LimitViolation", "MotionSource", "Trajectory", "check_limits"]
