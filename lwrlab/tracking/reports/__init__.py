"""What is read back from the store: ``lwrlab compare``, ``lwrlab report`` and the benchmark summary.

Owns the selection of finished job runs (:mod:`.run_selection`), their grouping by what was swept
(:mod:`.run_groups`), the comparison table (:mod:`.compare`, its self-contained page
:mod:`.compare_html`), the paper's tables and figures rebuilt from runs (:mod:`.report`), the runs
holding what is derived from other runs (:mod:`.derived_runs`) and the estimator benchmark's sweep
summary (:mod:`.benchmark_tables`, :mod:`.benchmark_summary`).
Reads through :mod:`lwrlab.tracking.runs`, :mod:`lwrlab.tracking.store` and
:mod:`lwrlab.tracking.job_config`; never through the callback's lifecycle or the companion.
"""
