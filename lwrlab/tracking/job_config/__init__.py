"""What tracking reads from a job's config and its surroundings, without touching a store.

Owns what a job's config says to tracking (flattened within MLflow's limits, its hash, its metrics:
:mod:`.config_params`), the few params that tell a run apart and its resolved config
(:mod:`.run_params`), the section each metric is filed under (``accuracy/rms_mean``:
:mod:`.metric_sections`), the logs or motions a job used as datasets (:mod:`.datasets`), the names a
reader of the store sees (experiments, runs: :mod:`.naming`), the tags saying where a run came from
(git commit, versions, process: :mod:`.provenance`) and the secrets kept out of everything logged
(:mod:`.redaction`). Pure functions and value types: the bottom
of :mod:`lwrlab.tracking`, importing none of its other sub-packages.
"""
