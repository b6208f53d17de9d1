"""Joint trajectories: the value object, and the protocol that motion plugins implement."""

from lwrlab.trajectory.core import LimitViolation, MotionSource, Trajectory, check_limits
from lwrlab.trajectory.parameterisation import LinearParameterisation

__all__ = ["LimitViolation", "LinearParameterisation", "MotionSource", "Trajectory", "check_limits"]
