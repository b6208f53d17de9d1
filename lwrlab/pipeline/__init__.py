"""Stages that wire the core from configured objects and write their artifacts, grouped by task.

Sub-packages, bottom up (each imports only those before it, and the shared modules):

- shared modules: :mod:`~lwrlab.pipeline.config_nodes` (reading config nodes),
  :mod:`~lwrlab.pipeline.config_checks` (checking a config before a run),
  :mod:`~lwrlab.pipeline.build` (the configured objects of a job);
- :mod:`~lwrlab.pipeline.identification`: task ``identification`` and its stages, predictions of logs;
- :mod:`~lwrlab.pipeline.excitation`: task ``excitation`` (an optimal exciting motion);
- :mod:`~lwrlab.pipeline.tools`: tool identification and recognition, payloads, drive gains;
- :mod:`~lwrlab.pipeline.monitor`: external torques and contacts of logs;
- :mod:`~lwrlab.pipeline.painting`: the painting chain (§IV–VI);
- :mod:`~lwrlab.pipeline.studies`: duration study, criteria comparison, estimator benchmark;
- :mod:`~lwrlab.pipeline.chain`: task ``paper_chain``, at the top.
"""
