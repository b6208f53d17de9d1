"""The run lifecycle of Hydra jobs and sweeps, hook by hook, in the process that runs the hooks.

Owns :class:`~.mlflow_callback.InProcessTracking` (the Hydra hooks and the stop signals they hold),
one job's run from start to end (:mod:`.job_run`), a sweep's parent run (:mod:`.sweep_run`) and the
ending of a sweep's runs when it stops (:mod:`.sweep_stop`), and the slot through which the callback
and the task function of one job talk (:mod:`.job_state`), and the later end of runs kept on disk
while the store was unreachable: their upload with their models (:mod:`.sync`, ``lwrlab sync``).
Builds on :mod:`lwrlab.tracking.runs`, :mod:`lwrlab.tracking.models`, :mod:`lwrlab.tracking.store`
and :mod:`lwrlab.tracking.job_config`; the callback the configs name
(:mod:`lwrlab.tracking.companion`) sits above it.
"""
