"""Cut-offs on point-to-point operation cycles: a work cell's log of quintic moves and dwells, fitted alone.

The zoo (``benchmarks/zoo.py --choice cutoff``) fits exciting motions and judges the model on new
motions; here the fit log itself is a 30 s cycle of short moves separated by rests
(``benchmarks/next_motion.py``'s :func:`operation_cycle` on the LWR4 and example-robot-data arms, the
simulated plant: 1 kHz, 0.1 N·m torque noise, seeded truths), the log a user most often has. Each cycle
is identified (weighted least squares, smooth Coulomb friction, as the next-motion benchmark) with the
processing's default cut-offs and with fixed ones, and scored against the truth: the base-parameter
error ‖β̂ − β‖/‖β‖ and the RMS error of the predicted torque against the true torque along the
paper's 20 s cross-validation motion (a motion the cycle never played).

    .venv/bin/python benchmarks/cutoff_cycles.py [--members lwr4 panda ur5 xarm7] [--seeds 0 1 2]

Prints the table (Markdown) per member and seed, and each option's errors over the default's (median
and range over the cycles), and the default's over the best option's of each cycle.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import pandas as pd

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))
sys.path.insert(0, str(REPOSITORY / "benchmarks"))

from next_motion import Designer, members, operation_cycle, processing, torque_error  # noqa: E402

from lwrlab.dynamics.base_parameters import compute_base_parameters  # noqa: E402
from lwrlab.identification.context import IdentificationContext  # noqa: E402
from lwrlab.identification.rows import identification_rows  # noqa: E402
from lwrlab.pipeline.build import build  # noqa: E402
from lwrlab.signal.processing import process  # noqa: E402

OPTIONS: dict[str, dict[str, Any]] = {
    "default": {"cutoff_hz": "auto", "state_cutoff_hz": "auto"},
    "auto, one filter": {"cutoff_hz": "auto", "state_cutoff_hz": None},
    **{f"{hz:g} Hz": {"cutoff_hz": hz, "state_cutoff_hz": None} for hz in (2.0, 5.0, 10.0, 20.0)},
}
"""The processing's cut-offs compared: the defaults, the rows' automatic cut-off on the states too
(one filter), and one fixed filter on q, τ and W."""


def identify(robot: Any, base: Any, measurement: Any, settings: dict[str, Any]) -> tuple[np.ndarray, str]:
    """Base parameters by conf/estimator/wls.yaml from ``measurement`` processed with ``settings``; and the
    cut-offs the processing chose."""
    data = process(measurement.t, measurement.q, measurement.tau, measurement.dq, **settings)
    estimator = build("estimator", "wls", n_joints=robot.n_joints)
    rows = identification_rows(robot, base, [data], estimator).weighted_near_rest()
    rows.fit(estimator, IdentificationContext.from_robot(robot, base, None))
    return np.asarray(estimator.phi_), f"{data.cutoff_hz:.3g} / {data.state_cutoff_hz:.3g}"


def run(names: list[str], seeds: list[int]) -> pd.DataFrame:
    """One row per member, seed and option: the cut-offs chosen and the errors against the truth."""
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        designer = Designer(Path(folder), fresh=False)
        validation = build("trajectory", "multisine_validation")
        for member in members(names):
            robot = member.robot
            base = compute_base_parameters(robot)
            problem = designer.source(10.0, build("criterion", "logdet")).problem(robot, base)
            for seed in seeds:
                plant = member.plant(seed)
                truth = plant.truth.robot
                true_beta = base.base_values(truth.parameters)
                cycle = operation_cycle(problem, np.random.default_rng(1000 * seed + 17))
                log = plant.measure(cycle)
                target = validation.sample(robot, 1000.0)
                for label, cutoffs in OPTIONS.items():
                    started = time.perf_counter()
                    beta, chosen = identify(robot, base, log, {**processing(), **cutoffs})
                    rows.append(
                        {
                            "member": member.name,
                            "seed": seed,
                            "option": label,
                            "cut-offs rows / states [Hz]": chosen,
                            "base-parameter error %": 100
                            * float(np.linalg.norm(beta - true_beta) / np.linalg.norm(true_beta)),
                            "validation torque RMS N·m": torque_error(truth, base, beta, target),
                        }
                    )
                    print(
                        f"  {member.name:6s} seed {seed} {label:17s} {chosen:14s} "
                        f"{rows[-1]['base-parameter error %']:8.3f} % "
                        f"{rows[-1]['validation torque RMS N·m']:8.4f} N·m  "
                        f"({time.perf_counter() - started:.1f} s)",
                        flush=True,
                    )
    return pd.DataFrame(rows)


ERRORS = {"base-parameter error %": "base-parameter error", "validation torque RMS N·m": "torque error"}


def summary(results: pd.DataFrame) -> pd.DataFrame:
    """Per option: its errors over the default's, the median and the extremes over members and seeds
    (above 1: the default is better); last, the default's over the best option's of each cycle."""
    out = []
    keys = ["member", "seed"]
    default = results[results["option"] == "default"].set_index(keys)
    for label in [label for label in OPTIONS if label != "default"]:
        mine = results[results["option"] == label].set_index(keys)
        entry: dict[str, Any] = {"option": label}
        for column, name in ERRORS.items():
            ratio = mine[column] / default[column]
            entry[f"{name} / default's, median"] = float(ratio.median())
            entry[f"{name} / default's, range"] = f"{ratio.min():.3g}–{ratio.max():.3g}"
        out.append(entry)
    best: dict[str, Any] = {"option": "default / best option of each cycle"}
    for column, name in ERRORS.items():
        ratio = default[column] / results.groupby(keys)[column].min()
        best[f"{name} / default's, median"] = float(ratio.median())
        best[f"{name} / default's, range"] = f"{ratio.min():.3g}–{ratio.max():.3g}"
    return pd.DataFrame([*out, best])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--members", nargs="*", default=["lwr4", "panda", "ur5", "xarm7"])
    parser.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2])
    args = parser.parse_args()
    results = run(args.members, args.seeds)
    print("\n## Cut-offs on point-to-point cycles\n")
    print(results.to_markdown(index=False, floatfmt=".3g"))
    print("\n## Cut-offs on point-to-point cycles, against the default\n")
    print(summary(results).to_markdown(index=False, floatfmt=".3g"))


if __name__ == "__main__":
    main()
