"""Identification: the estimator protocol and the statistics of estimated parameters."""

from lwrlab.identification.core import Estimator, relative_std, torque_errors

__all__ = ["Estimator", "relative_std", "torque_errors"]
