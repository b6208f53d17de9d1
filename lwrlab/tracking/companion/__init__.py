"""The tracking callback the configs name, and the companion process it logs a single run from.

Owns :class:`~.callback.MlflowTracking` (``_target_: lwrlab.tracking.MlflowTracking``), which logs a
sweep's jobs in their own process and a single run from a companion process so that the job never
imports MLflow: the job's side of the link (:mod:`.companion_link`), the companion itself
(:mod:`.process`) and its early start before Hydra composes the config (:mod:`.early_companion`).
The top of the package: it may import every other sub-package but :mod:`lwrlab.tracking.reports`.
"""
