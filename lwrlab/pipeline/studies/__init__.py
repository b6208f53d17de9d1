"""The studies: many identifications or motions compared, each a task of its own.

- :mod:`~lwrlab.pipeline.studies.duration_study`: task ``duration_study`` (Fig. 5), the optimal cost
  of every criterion against the motion's duration;
- :mod:`~lwrlab.pipeline.studies.criteria_comparison`: task ``criteria_comparison`` (Fig. 6), which
  criterion's motion identifies best;
- :mod:`~lwrlab.pipeline.studies.estimator_benchmark`: task ``estimator_benchmark``, one
  (estimator, noise, seed) cell of the estimator benchmark.

They sit above :mod:`lwrlab.pipeline.excitation` and :mod:`lwrlab.pipeline.identification`.
"""
