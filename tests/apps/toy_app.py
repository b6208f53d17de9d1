"""A tiny Hydra app for the tracking tests: writes a CSV, returns metrics, fails on request.

Run from the tests with the repository's ``conf/`` on the search path, so that ``tracking: sqlite``
is the real tracking config of the project::

    python tests/apps/toy_app.py hydra.searchpath=[file:///abs/repo/conf] x=3 fail=true

Two ways to keep a job busy, so that a test stops it mid-job (both outside the config, so that a
resumed sweep has the same hash): ``TOY_SLEEP_S`` sleeps that long; ``TOY_HOLD_DIR`` announces the
job in that folder (``started-<pid>-<random>``, holding its overrides, written once its CSV is) and
waits until the test creates ``release`` there. ``TOY_REPORT_PROCESS`` makes the job write which
process ran it (``job_process.json``).
"""

from __future__ import annotations

import json
import os
import sys
import time
import uuid
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

import lwrlab.conf  # noqa: F401  (registers the schemas of lwrlab's tracking configs: read as file://)

RELEASE_FILE = "release"
"""Created by a test in ``TOY_HOLD_DIR`` to let the held jobs go on."""
PROCESS_FILE = "job_process.json"
"""Written when ``TOY_REPORT_PROCESS`` is set: the job's pid and whether its process imported mlflow."""


def hold(folder: Path, overrides: list[str]) -> None:
    """Say that this job runs (``started-<pid>-<random>``: its overrides), then wait for ``folder/release``.

    A pool worker runs several jobs: the random part keeps their announcements apart.
    """
    announcement = folder / f"started-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    draft = folder / f".{announcement.name}.tmp"
    draft.write_text(" ".join(overrides), encoding="utf-8")
    draft.rename(announcement)  # seen whole, or not at all
    while not (folder / RELEASE_FILE).exists():
        time.sleep(0.1)


@hydra.main(version_base="1.3", config_path="conf", config_name="config")
def main(cfg: DictConfig) -> dict[str, object]:
    """Write ``table.csv`` into the job output folder, then fail if ``cfg.fail``, else return metrics."""
    output_dir = Path(HydraConfig.get().runtime.output_dir)
    (output_dir / "table.csv").write_text(f"x,doubled\n{cfg.x},{2 * cfg.x}\n", encoding="utf-8")
    time.sleep(float(os.environ.get("TOY_SLEEP_S", "0")))
    if os.environ.get("TOY_HOLD_DIR"):
        hold(Path(os.environ["TOY_HOLD_DIR"]), list(HydraConfig.get().overrides.task))
    if os.environ.get("TOY_REPORT_PROCESS"):  # which process ran the job, and whether it imported MLflow
        report = {"pid": os.getpid(), "imported_mlflow": "mlflow" in sys.modules}
        (output_dir / PROCESS_FILE).write_text(json.dumps(report), encoding="utf-8")
    if cfg.fail:
        raise RuntimeError(f"toy failure requested with x={cfg.x}")
    # A failure from outside the config (a crashed node, a full disk): the same config succeeds later.
    if os.environ.get("TOY_TRANSIENT_FAILURE_X") == str(cfg.x):
        raise RuntimeError(f"transient failure of the job with x={cfg.x}")
    return {
        "metrics": {"doubled": 2.0 * cfg.x, "per_joint_rms": [0.5, 0.25], "label": "not a number"},
        "report": "ignored by the tracking callback",
    }


if __name__ == "__main__":
    main()
