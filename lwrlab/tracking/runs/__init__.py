"""Runs in the store and the processes behind them: logged, searched, ended when their process is gone.

Owns what a run receives (params and metrics in batches, the job output folder, the files that tie
a folder to its run: :mod:`.run_logging`; its datasets: :mod:`.run_datasets`), a sweep's summary on
its parent run (:mod:`.sweep_summary`), the view of an experiment's runs saved for MLflow's UI and
the link that opens it (:mod:`.view_state`, :mod:`.runs_view`), the searches of the store
(:mod:`.run_queries`), the ending of runs a stopped or dead process left RUNNING (:mod:`.finalise`,
with the process and signal helpers of :mod:`.processes`), the records of runs kept on disk while
the store was unreachable (:mod:`.offline`; their later upload with their models is
:mod:`lwrlab.tracking.lifecycle.sync`),
and a failed job's error in a form that crosses processes (:mod:`.forwarded_error`). Imports
:mod:`lwrlab.tracking.store` and :mod:`lwrlab.tracking.job_config`, never the callback's lifecycle,
the companion or the reports.
"""
