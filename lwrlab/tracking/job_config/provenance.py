"""Where a run came from: git commit and dirty state, library versions, user, process, and a job's tags.

:func:`provenance_tags` says which code ran (``git_commit``, ``git_dirty``, ``lwrlab_version``, …);
:func:`process_tags` says which process runs the run (``pid``, ``hostname``: how
:mod:`lwrlab.tracking.runs.finalise` tells a run left RUNNING by a dead process from one still running);
:func:`job_tags` adds what identifies one Hydra job: its overrides, config hash, seed, output folder
and its sweep.

Examples
--------
>>> sorted(provenance_tags(Path("/")))[:3]  # doctest: +SKIP
['hydra_version', 'lwrlab_version', 'mlflow.user']
>>> sorted(process_tags())
['hostname', 'pid']
"""

from __future__ import annotations

import functools
import getpass
import logging
import os
import platform
import socket
import subprocess
from collections.abc import Iterable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

import mlflow
from omegaconf import DictConfig, OmegaConf

import lwrlab
from lwrlab.tracking.job_config.config_params import (
    TAG_VALUE_MAX_LENGTH,
    config_hash,
    is_sweep_job,
    original_cwd,
    task_overrides,
    truncate,
)

log = logging.getLogger(__name__)

RUN_KIND_TAG = "run_kind"
"""``job``, ``sweep``, ``compare`` or ``report``: filter with ``runs_table(..., "tags.run_kind = 'job'")``."""
PARENT_RUN_TAG = "mlflow.parentRunId"
"""Nests a run under another (a sweep's job under the sweep) in the MLflow UI."""
PID_TAG = "pid"
"""The id of the process that runs the run (with ``hostname``: whether that process still lives)."""
HOSTNAME_TAG = "hostname"
"""The machine of that process."""
GIT_TIMEOUT_S = 5


def _package_version(*distributions: str) -> str:
    for distribution in distributions:
        try:
            return metadata.version(distribution)
        except metadata.PackageNotFoundError:
            continue
    return "not installed"


def _git(args: Iterable[str], cwd: Path) -> str | None:
    """Output of a git command in ``cwd``, or ``None`` (not a repository, no git, too slow)."""
    try:
        completed = subprocess.run(
            ["git", *args], cwd=cwd, capture_output=True, text=True, timeout=GIT_TIMEOUT_S, check=False
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return completed.stdout.strip() if completed.returncode == 0 else None


@functools.lru_cache(maxsize=8)  # git runs once per process and launch folder, not once per job
def provenance_tags(cwd: Path) -> dict[str, str]:
    """Tags that say which code ran: git commit and dirty state (``cwd`` in a repository), versions."""
    tags = {
        "lwrlab_version": lwrlab.__version__,
        "numpy_version": _package_version("numpy"),
        "pinocchio_version": _package_version("pin", "pinocchio"),
        "mlflow_version": mlflow.__version__,
        "hydra_version": _package_version("hydra-core"),
        "python_version": platform.python_version(),
    }
    commit = _git(["rev-parse", "HEAD"], cwd)
    if commit:
        tags["git_commit"] = commit
        tags["mlflow.source.git.commit"] = commit  # shown by the MLflow UI
        changes = _git(["status", "--porcelain", "--untracked-files=no"], cwd)
        if changes is not None:
            tags["git_dirty"] = str(bool(changes)).lower()
    try:
        tags["mlflow.user"] = getpass.getuser()
    except (KeyError, OSError) as error:  # no user name in some containers (KeyError before 3.13)
        log.debug("no user name for the mlflow.user tag (%s: %s)", type(error).__name__, error)
    return tags


def process_tags() -> dict[str, str]:
    """Tags naming the process that runs a run: ``pid`` and ``hostname``."""
    return {PID_TAG: str(os.getpid()), HOSTNAME_TAG: socket.gethostname()}


def job_tags(
    config: DictConfig,
    job_config: Mapping[str, Any],
    parent_run_id: str | None,
    hashed_text: str | None = None,
) -> dict[str, str]:
    """The tags of a job's run: what it computes (overrides, config hash, seed), where and which code ran.

    Parameters
    ----------
    config
        The job's full config (with its ``hydra`` node).
    job_config
        The same config resolved, without the ``hydra`` node (see
        :func:`~lwrlab.tracking.job_config.config_params.resolved_job_config`).
    parent_run_id
        The sweep's parent run, if the job is one of a tracked sweep.
    hashed_text
        The hashed part of the resolved config as YAML, when already made
        (:func:`~lwrlab.tracking.job_config.config_params.hashed_config_text`).
    """
    tags = {
        RUN_KIND_TAG: "job",
        "overrides": truncate(" ".join(task_overrides(config)), TAG_VALUE_MAX_LENGTH),
        "config_hash": config_hash(job_config, hashed_text),
        "hydra_job_name": str(OmegaConf.select(config, "hydra.job.name", default="")),
        "hydra_output_dir": str(config.hydra.runtime.output_dir),
        **provenance_tags(original_cwd(config)),
        **process_tags(),
        # the UI's Source column: the command that ran, as a user would type it again
        "mlflow.source.type": "LOCAL",
        "mlflow.source.name": truncate(
            " ".join(["lwrlab", *task_overrides(config)]) or "lwrlab", TAG_VALUE_MAX_LENGTH
        ),
    }
    if "seed" in job_config:
        tags["seed"] = str(job_config["seed"])
    if is_sweep_job(config):
        tags["hydra_job_num"] = str(OmegaConf.select(config, "hydra.job.num", default=""))
    if parent_run_id is not None:
        tags[PARENT_RUN_TAG] = parent_run_id
    return tags


__all__ = [
    "HOSTNAME_TAG",
    "PARENT_RUN_TAG",
    "PID_TAG",
    "RUN_KIND_TAG",
    "job_tags",
    "process_tags",
    "provenance_tags",
]
