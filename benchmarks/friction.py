"""What ``friction=auto`` costs: a 10 s, 1 kHz identification from a log with the paper's law and with auto.

The simulated LWR4's shipped optimal 10 s motion and its 20 s validation motion are written as logs
(Parquet, 1 kHz), then identified in this process with the defaults for logs (``estimator=sdp``,
``weight: auto``) and ``friction=sign`` (the baseline: the law before) or ``friction=auto`` (the
default for logs: every law of ``conf/friction/auto.yaml`` at each point of its shape grid, with and
without rotor inertias, chosen by block cross-validation), alternately, ``--repeats`` times each; the
median wall times and their ratio are printed, with the choice, the number of candidates scored (read
from the run, not assumed: 32 with the shipped grid) and the validation error.
Imports and the first composition are paid before the clock starts.

    .venv/bin/python benchmarks/friction.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from benchmarks.processing_study import simulated_lwr4  # noqa: E402
from lwrlab.io.logs import write_log  # noqa: E402


def _logs(folder: Path) -> tuple[Path, Path]:
    from hydra.utils import instantiate

    cfg, robot, plant = simulated_lwr4(0)
    fit = plant.measure(instantiate(cfg.trajectory).sample(robot, cfg.measurement.rate_hz))
    validation = plant.measure(instantiate(cfg.validation).sample(robot, cfg.measurement.rate_hz))
    return write_log(fit, folder / "fit.parquet"), write_log(validation, folder / "validation.parquet")


def _identify(fit: Path, validation: Path, friction: str) -> tuple[float, object]:
    from hydra import compose, initialize_config_dir

    import lwrlab.conf  # noqa: F401  (registers the schemas)
    from lwrlab.pipeline.identification import identify_configured

    with initialize_config_dir(config_dir=str(REPOSITORY / "conf"), version_base=None):
        cfg = compose(
            "config",
            overrides=[
                "task=identification",
                "plant=log",
                f"data.paths=[{fit}]",
                f"data.validation_paths=[{validation}]",
                f"friction={friction}",
            ],
        )
    start = time.perf_counter()
    report = identify_configured(cfg)
    return time.perf_counter() - start, report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory() as folder:
        fit, validation = _logs(Path(folder))
        _identify(fit, validation, "sign")  # imports, compiled solvers: not timed
        times: dict[str, list[float]] = {"sign": [], "auto": []}
        reports = {}
        for _ in range(args.repeats):
            for friction in times:
                wall, reports[friction] = _identify(fit, validation, friction)
                times[friction].append(wall)
    print("| friction | median wall (s) | validation ‖τ−τ̂‖/‖τ‖ | law | candidates scored |")
    print("|---|--:|--:|---|--:|")
    for friction, walls in times.items():
        report = reports[friction]
        choice = report.friction_choice  # type: ignore[attr-defined]
        law = choice.candidate.label if choice is not None else friction
        metrics = report.metrics  # type: ignore[attr-defined]
        error = 100 * metrics["validation_rel_error"]
        candidates = int(metrics.get("friction_candidates", 1))  # absent: no choice made (one law)
        print(f"| {friction} | {np.median(walls):.2f} | {error:.3f} % | {law} | {candidates} |")
    print(f"\nauto / sign: {np.median(times['auto']) / np.median(times['sign']):.2f}×")


if __name__ == "__main__":
    main()
