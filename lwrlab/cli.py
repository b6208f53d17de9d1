"""Command-line entry point: ``lwrlab [group=option ...] [key=value ...]`` (a Hydra app).

Four subcommands work on the MLflow store instead of running a job (dispatched before Hydra starts):
``lwrlab report --help`` (the paper's tables and figures rebuilt from logged runs),
``lwrlab compare --help`` (headline metrics grouped by what was swept, seeds as replication),
``lwrlab sync --help`` (upload runs kept on disk while the store was unreachable) and
``lwrlab model --help`` (registered identified models: aliases such as ``champion``, versions).
"""

from __future__ import annotations

import importlib
import logging
import sys
from pathlib import Path
from typing import Any

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.errors import CompactHydraException
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf

import lwrlab.conf  # noqa: F401  (registers the schemas: Hydra's --info defaults looks them up first)
from lwrlab.errors import UserError
from lwrlab.garbage_collection import freeze_heap_at_exit, relax_garbage_collection
from lwrlab.hydra_error_lines import one_line_user_errors
from lwrlab.numerics.threads import limit_process_blas_threads
from lwrlab.pipeline.config_checks import check_config
from lwrlab.resources import CONFIG_SEARCH_PATH
from lwrlab.tracking.companion import early_companion
from lwrlab.tracking.lifecycle import job_state
from lwrlab.tracking.models import resolve
from lwrlab.tracking.runs.processes import JobInterrupted

log = logging.getLogger("lwrlab")

VERSIONED_DISTRIBUTIONS = ("hydra-core", "pin", "numpy", "scipy", "cvxpy", "mlflow", "mujoco")
"""The libraries whose versions ``lwrlab --version`` names (what a bug report needs)."""

SUBCOMMANDS = {
    "report": "lwrlab.tracking.reports.report",
    "compare": "lwrlab.tracking.reports.compare",
    "sync": "lwrlab.tracking.lifecycle.sync",
    "model": "lwrlab.tracking.models.registry",
}
"""``lwrlab <name> ...`` runs ``<module>.main(argv)`` instead of a Hydra job."""


class UserFacingError(CompactHydraException):
    """A :class:`~lwrlab.errors.UserError` handed to Hydra, which prints such errors as their message
    alone and exits with status 1; the tracking callback still records the run FAILED with the whole
    traceback in ``error.txt``."""


def _user_error(error: BaseException) -> UserError | None:
    """The user error behind ``error`` (itself, or a cause: Hydra wraps errors raised by its plugins)."""
    seen: BaseException | None = error
    while seen is not None:
        if isinstance(seen, UserError):
            return seen
        seen = seen.__cause__
    return None


def run(cfg: DictConfig, output_dir: Path) -> dict[str, float]:
    """Run the pipeline stage selected by ``cfg.task`` (a function ``(cfg, output_dir) -> metrics``).

    The models the stage read (``task.model``, ``robot.source``, …) are written into the output
    folder (:data:`~lwrlab.tracking.models.resolve.MODEL_INPUTS_FILE`), failed or not: the tracking
    callback tags the run with them.
    """
    finished = job_state.completed_metrics()
    if finished is not None:  # a re-launched sweep: the tracking callback found this config FINISHED
        log.info(
            "this job's config already finished in MLflow: its metrics are reused, nothing is recomputed"
        )
        return finished
    check_config(cfg)  # a wrong type or range fails here, naming the key, before anything is built
    resolve.forget_models_used()
    try:
        stage = instantiate(cfg.task)
        metrics = stage(cfg, output_dir)
    finally:
        resolve.write_models_used(output_dir)
    log.info("artifacts written to %s", output_dir)
    return metrics


@hydra.main(version_base="1.3", config_path=CONFIG_SEARCH_PATH, config_name="config")
def hydra_app(cfg: DictConfig) -> dict[str, float] | float:
    """Hydra entry point; the tracking callback logs the metrics and the output folder.

    With ``objective=<metric>`` (set by tuning presets) the job returns that one number, which a
    sweeper such as Optuna minimises; all metrics are still logged.
    """
    try:
        metrics = run(cfg, Path(HydraConfig.get().runtime.output_dir))
    except Exception as error:
        user_error = _user_error(error)
        if user_error is None:
            raise  # a bug: Hydra prints the traceback
        raise UserFacingError(f"lwrlab: {user_error}") from error
    job_state.record_metrics(metrics)
    objective = OmegaConf.select(cfg, "objective", default=None)
    if objective is None:
        return metrics
    if objective not in metrics:
        raise KeyError(f"objective {objective!r} is not a metric of this task; metrics: {sorted(metrics)}")
    return float(metrics[objective])


def version_text() -> str:
    """``lwrlab <version> (Python <version>; <library> <version>, …)``, read without importing them.

    Examples
    --------
    >>> version_text().startswith("lwrlab ") and "hydra-core " in version_text()
    True
    """
    import platform
    from importlib.metadata import PackageNotFoundError, version

    from lwrlab import __version__

    found = []
    for distribution in VERSIONED_DISTRIBUTIONS:
        try:
            found.append(f"{distribution} {version(distribution)}")
        except PackageNotFoundError:
            found.append(f"{distribution} missing")
    return f"lwrlab {__version__} (Python {platform.python_version()}; {', '.join(found)})"


def main() -> Any:
    """``lwrlab report|compare|sync ...`` (see their ``--help``), otherwise the Hydra app.

    A stop signal (SIGINT, SIGTERM) ends the process with the shell's status for it (130, 143) after
    the tracking callback has ended the runs KILLED. A user's error is one ``lwrlab:`` line
    (:mod:`lwrlab.hydra_error_lines`; ``HYDRA_FULL_ERROR=1`` prints its whole traceback). BLAS runs
    one thread unless the environment says otherwise
    (:func:`~lwrlab.numerics.threads.limit_process_blas_threads`), and the garbage collector runs less
    often, and not over the whole heap again at exit (:mod:`lwrlab.garbage_collection`).
    """
    limit_process_blas_threads()  # before anything imports numpy
    relax_garbage_collection()
    freeze_heap_at_exit()
    if len(sys.argv) > 1 and sys.argv[1] in SUBCOMMANDS:
        command = importlib.import_module(SUBCOMMANDS[sys.argv[1]])
        sys.exit(command.main(sys.argv[2:]))
    if "--version" in sys.argv[1:]:  # Hydra's own flag would name Hydra's version alone
        print(version_text())
        sys.exit(0)
    if early_companion.may_log_a_single_run(sys.argv[1:]):
        early_companion.launch()  # MLflow loads while Hydra composes the config
    try:
        with one_line_user_errors():  # HYDRA_FULL_ERROR=1: Hydra's whole output, the traceback
            return hydra_app()
    except JobInterrupted as stop:
        print(f"lwrlab: {stop}; runs in flight ended KILLED", file=sys.stderr)
        sys.exit(stop.exit_status)


if __name__ == "__main__":
    main()
