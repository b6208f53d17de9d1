"""The MLflow store a job logs to: which one, how it is reached, and its safe use by many processes.

Owns the tracking settings as each job's config resolves them (:mod:`.settings`), the connection
probed and prepared once per process with its experiment ensured (:mod:`.connection`), a SQLite store
made safe under parallel jobs (a migrated template schema, locks, retries on ``database is locked``:
:mod:`.sqlite`, :mod:`.schema_template`) and the files of an earlier run fetched by run id
(:mod:`.run_artifacts`). Imports only :mod:`lwrlab.tracking.job_config` of the tracking package.
"""
