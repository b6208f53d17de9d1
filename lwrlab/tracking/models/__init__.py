"""Identified models as MLflow Models: logged with the run that identified them, registered, read back.

Owns the pyfunc model of an identified robot (joint states in, torques out:
:mod:`.identified_pyfunc`, loaded by MLflow through :mod:`.identified_model_code`) and of an
identified payload (the torques it adds: :mod:`.payload_pyfunc`, :mod:`.payload_model_code`), their
logging at the end of an identification's or a payload's run with the models a job read as that
run's inputs (:mod:`.model_logging`), the Model Registry (a version per identification when
``tracking.register_model`` says so, its aliases and the ``lwrlab model`` command: :mod:`.registry`)
and the resolution of any model setting, a path or an MLflow URI, to a local file
(:mod:`.resolve`, which imports MLflow only when a URI is looked up). Imports
:mod:`lwrlab.tracking.runs`, :mod:`lwrlab.tracking.store` and :mod:`lwrlab.tracking.job_config`; the
lifecycle calls it at a job's end.
"""
