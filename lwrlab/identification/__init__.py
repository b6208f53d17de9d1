"""Identification, the whole computation: from measurements to an identified model and its report.

The estimator protocol and the statistics of estimated parameters (:mod:`.core`, :mod:`.least_squares`,
:mod:`.bootstrap`, :mod:`.prior_weight`, …), the friction law the data choose
(:mod:`.friction_choice`), and the stages of an identification, bottom up:

- :mod:`.rows`: the identification rows of processed logs, block by block;
- :mod:`.log_predictions`: one log processed and predicted by a model, with its interval and tables;
- :mod:`.measuring`, :mod:`.fitting`, :mod:`.scoring`, :mod:`.notes`: measure and process, choose
  the drive terms and fit, predict and score, and the notes a reader needs;
- :mod:`.state_cutoff`: the states' cut-off a model predicts with, chosen by its fit logs' raw torques;
- :mod:`.result`: :class:`~lwrlab.identification.result.IdentificationReport`, the result in memory.

Pure computation: the task that wires them from a config and writes the files is
:mod:`lwrlab.pipeline.identification`.
"""

from lwrlab.identification.core import Estimator, relative_std, torque_errors

__all__ = ["Estimator", "relative_std", "torque_errors"]
