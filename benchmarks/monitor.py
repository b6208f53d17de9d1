"""Monitoring benchmark: collision detection and external torques where the truth is known.

1. The observer's cost: the real-time step function (one sample, 7 joints) and the vectorised form
   over a log, µs per sample.
2. The MuJoCo scenario (:mod:`lwrlab.pipeline.monitor.scenario`): a perturbed LWR4 identified from its
   contact-free logs, then ``--contact-free-s`` seconds of contact-free motion followed by pushes
   (5–50 N, 50–500 ms) and impacts on links 3–7 during ``--contact-s`` seconds. Thresholds from the
   identification logs. Scored for the identified and the CAD model, state and constant
   thresholds, the momentum observer and the direct residual: contacts of ≥ 10 N missed, those of
   them detectable (their true external joint torque above some joint's threshold for the minimum
   duration) and missed, false alarms (and those in the contact-free stretch),
   median and largest detection delay, external torque RMS error (against the truth seen through
   each estimator's filter, and against the raw truth), force RMS error at the true contact point
   over each push's plateau (median over pushes).
3. The real LWR4+ (``../shared/data/kuka_lwr4_hw``, skipped without it): model and thresholds from
   runs 2 + 3, run 1 monitored (contact-free: every detection is a false alarm).
4. Crossed, constant against state thresholds (``task.thresholds``), both measured in the same run:

   - the real LWR4+: model and thresholds from one run, every other run monitored (runs 1 and 2
     repeat one motion, run 3 is another, faster one): false alarms, per direction and per hour of
     monitored log in all;
   - MuJoCo (:mod:`lwrlab.pipeline.monitor.crossed`): a model and thresholds from an exciting motion
     and a moderate motion family, then slower, faster and stopping motions with pushes and impacts,
     the runs' friction differing by ``--drift``, and the arm standing still, pushed by hand: contacts
     of ≥ 10 N detected, detectable and missed, false alarms, median and largest delay, median
     threshold.

    .venv/bin/python benchmarks/monitor.py                       # about 4 minutes on 2 cores
    .venv/bin/python benchmarks/monitor.py --contact-free-s 60 --contact-s 60 --crossed-s 30   # a quick look

The scenario's files stay in ``--output`` (default outputs/monitor_scenario): ``task=monitor`` reads
them as any logs (the command is printed).
"""

from __future__ import annotations

import argparse
import sys
import time
import timeit
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from lwrlab.figures.monitor import external_torques  # noqa: E402
from lwrlab.io.logs import load_log  # noqa: E402
from lwrlab.model.robot import RobotModel  # noqa: E402
from lwrlab.monitoring.estimates import (  # noqa: E402
    ESTIMATORS,
    THRESHOLD_KINDS,
    ExternalTorques,
    MonitorSettings,
    calibrate,
    detect,
    estimate_external_torques,
    thresholds_of,
    truth_as_estimated,
)
from lwrlab.monitoring.observer import MomentumObserver, observer_step  # noqa: E402
from lwrlab.monitoring.scoring import (  # noqa: E402
    contact_force_errors,
    detectable_contacts,
    rms_error,
    score_detections,
)
from lwrlab.pipeline.build import build  # noqa: E402
from lwrlab.pipeline.monitor.crossed import write_crossed_scenario  # noqa: E402
from lwrlab.pipeline.monitor.scenario import identify_logs, write_scenario  # noqa: E402

REAL_LWR4 = REPOSITORY.parent / "shared" / "data" / "kuka_lwr4_hw"
NPZ_MAP = {"t": "times", "q": "positions", "dq": "velocities", "tau": "torques"}
REAL_OVERRIDES = (
    "robot=urdf",
    f"robot.path={REAL_LWR4 / 'kuka_lwr4.urdf'}",
    "data.column_map={t: times, q: positions, dq: velocities, tau: torques}",
)
"""How ``task=identification plant=log`` reads the real LWR4+ runs."""


def settings() -> MonitorSettings:
    """The shipped settings of ``task=monitor`` (conf/task/monitor.yaml)."""
    from lwrlab.pipeline.build import shipped_config

    task = shipped_config("task", "monitor")
    return MonitorSettings(
        observer_gain=float(task.observer_gain),
        velocity_cutoff_hz=float(task.velocity_cutoff_hz),
        coulomb_smoothing=float(task.coulomb_smoothing),
        false_alarm_rate=float(task.false_alarm_rate),
        margin=float(task.margin),
        min_duration=float(task.min_duration),
        release=float(task.release),
        residual_margin=float(task.residual_margin),
        thresholds=str(task.thresholds),
        friction_drift=float(task.friction_drift),
        rest_thresholds=str(task.rest_thresholds),
    )


def identified_robot(path: Path) -> RobotModel:
    """The robot of an ``identified_model.yaml``, built as ``robot=identified`` builds it."""
    return build("robot", "identified", source=str(path))


def step_cost(robot: RobotModel, gain: float) -> tuple[float, float]:
    """µs per sample of the step function and of the vectorised form (7 joints, 1 kHz samples)."""
    observer = MomentumObserver(robot, gain)
    rng = np.random.default_rng(0)
    q, dq, tau = (rng.normal(size=robot.n_joints) for _ in range(3))
    state = observer.start(0.0, q, dq, tau)
    repeats = 20_000
    step = min(
        timeit.repeat(lambda: observer_step(observer, state, 1e-3, q, dq, tau), number=repeats, repeat=5)
    )
    n = 50_000
    t = np.arange(n) * 1e-3
    qs, dqs, taus = (rng.normal(size=(n, robot.n_joints)) for _ in range(3))
    start = time.perf_counter()
    observer.observe(t, qs, dqs, taus)
    return 1e6 * step / repeats, 1e6 * (time.perf_counter() - start) / n


def score(
    robot: RobotModel,
    calibration_logs: list[ExternalTorques],
    monitored: ExternalTorques,
    contacts: pd.DataFrame,
    truth: np.ndarray,
    contact_free_s: float,
    chosen: MonitorSettings,
) -> dict[str, dict[str, float]]:
    """Each estimator's figures on the monitored log."""
    calibrations = calibrate(calibration_logs, chosen)
    found = detect(monitored, calibrations, chosen)
    seen = truth_as_estimated(truth, monitored, chosen)
    keep = monitored.monitored
    rows = {}
    for estimator in ESTIMATORS:
        detectable = detectable_contacts(
            monitored.t,
            np.where(keep[:, None], truth, 0.0),
            contacts,
            thresholds_of(monitored, calibrations, estimator),
            min_duration=chosen.min_duration,
        )
        result = score_detections(found[estimator], contacts, detectable=detectable)
        free = [d for d in found[estimator] if d.start < contact_free_s]
        estimate = monitored.estimate(estimator)
        settle = 5.0 / chosen.observer_gain if estimator == "observer" else 2.0 / chosen.velocity_cutoff_hz
        forces = contact_force_errors(robot, monitored.t, monitored.q, estimate, contacts, settle=settle)
        rows[estimator] = {
            "contacts ≥ 10 N": result.contacts,
            "missed": result.missed,
            "detectable": result.detectable,
            "detectable missed": result.missed_detectable,
            "false alarms": result.false_alarms,
            "false alarms, contact-free stretch": len(free),
            "median delay [ms]": 1000 * result.median_delay,
            "max delay [ms]": 1000 * float(result.delays.max()) if result.delays.size else float("nan"),
            "τ_ext RMS error [N·m]": float(np.mean(rms_error(estimate[keep], seen[estimator][keep]))),
            "τ_ext RMS error, raw truth [N·m]": float(np.mean(rms_error(estimate[keep], truth[keep]))),
            "force RMS error [N]": float(np.nanmedian(forces)) if forces.size else float("nan"),
        }
    return rows


def scenario_table(
    folder: Path, contact_free_s: float, contact_s: float, chosen: MonitorSettings
) -> pd.DataFrame:
    """The MuJoCo scenario's figures per model, kind of thresholds and estimator."""
    start = time.perf_counter()
    files = write_scenario(folder, contact_free_s=contact_free_s, contact_s=contact_s)
    print(f"scenario simulated and identified in {time.perf_counter() - start:.0f} s ({folder})")
    cad = build("robot", "kuka_lwr4")
    logs = {
        name: load_log(path, 7).to_measurement()
        for name, path in (
            ("identification", files.identification),
            ("validation", files.validation),
            ("monitored", files.monitored),
        )
    }
    contacts = pd.read_csv(files.contacts)
    truth = pd.read_parquet(files.truth)[[f"tau_ext{j}" for j in range(1, 8)]].to_numpy()
    rows = []
    for name, robot in (("identified", identified_robot(files.model)), ("CAD", cad)):
        start = time.perf_counter()
        reference = [
            estimate_external_torques(robot, logs[k], chosen) for k in ("identification", "validation")
        ]
        monitored = estimate_external_torques(robot, logs["monitored"], chosen)
        seconds = time.perf_counter() - start
        for kind in THRESHOLD_KINDS:
            kind_settings = replace(chosen, thresholds=kind)
            for estimator, figures in score(
                robot, reference, monitored, contacts, truth, contact_free_s, kind_settings
            ).items():
                rows.append({"model": name, "thresholds": kind, "estimator": estimator, **figures})
        print(f"{name}: {len(logs['monitored'].t)} samples monitored in {seconds:.1f} s (both estimators)")
    print(
        "\nthe same logs through the CLI:\n  lwrlab task=monitor plant=log "
        f"task.model={files.model} 'task.calibration_paths=[{files.identification},{files.validation}]' "
        f"'data.paths=[{files.monitored}]' task.truth_contacts={files.contacts} "
        f"task.truth_torque={files.truth}"
    )
    return pd.DataFrame(rows)


def real_lwr4_row(folder: Path, chosen: MonitorSettings) -> dict[str, object] | None:
    """Model and thresholds from runs 2 + 3, run 1 monitored; None without the data."""
    if not (REAL_LWR4 / "measurements_1.npz").is_file():
        print(f"real LWR4+ logs not found at {REAL_LWR4}: skipped")
        return None
    runs = {i: REAL_LWR4 / f"measurements_{i}.npz" for i in (1, 2, 3)}
    model = identify_logs(
        folder / "lwr4plus_identified_model.yaml", [runs[2], runs[3]], [runs[1]], REAL_OVERRIDES
    )
    robot = identified_robot(model)
    measured = {i: load_log(runs[i], 7, column_map=NPZ_MAP).to_measurement() for i in runs}
    reference = [estimate_external_torques(robot, measured[i], chosen) for i in (2, 3)]
    monitored = estimate_external_torques(robot, measured[1], chosen)
    found = detect(monitored, calibrate(reference, chosen), chosen)
    return {
        "monitored": f"run 1 ({monitored.monitored_hours * 3600:.0f} s)",
        "detections (observer)": len(found["observer"]),
        "detections (direct residual)": len(found["residual"]),
    }


def real_lwr4_crossed(folder: Path, chosen: MonitorSettings) -> pd.DataFrame | None:
    """Per direction (model and thresholds from run i, run j monitored) and kind of thresholds, the
    false alarms of both estimators (the observer's on stretches whose logged velocities contradict
    the positions counted apart too); None without the data. Draws the 2 → 3 direction's torques and
    state thresholds (``real_lwr4_2_to_3.png``)."""
    if not (REAL_LWR4 / "measurements_1.npz").is_file():
        print(f"real LWR4+ logs not found at {REAL_LWR4}: crossed directions skipped")
        return None
    runs = {i: REAL_LWR4 / f"measurements_{i}.npz" for i in (1, 2, 3)}
    measured = {i: load_log(runs[i], 7, column_map=NPZ_MAP).to_measurement() for i in runs}
    rows = []
    for i in runs:
        others = [runs[j] for j in runs if j != i]
        model = identify_logs(folder / f"lwr4plus_run{i}_model.yaml", [runs[i]], others, REAL_OVERRIDES)
        robot = identified_robot(model)
        estimates = {j: estimate_external_torques(robot, measured[j], chosen) for j in runs}
        for kind in THRESHOLD_KINDS:
            kind_settings = replace(chosen, thresholds=kind)
            calibrations = calibrate([estimates[i]], kind_settings)
            for j in (j for j in runs if j != i):
                found = detect(estimates[j], calibrations, kind_settings)
                rows.append(
                    {
                        "direction": f"{i} → {j}",
                        "thresholds": kind,
                        "monitored [s]": estimates[j].monitored_hours * 3600,
                        "false alarms (observer)": len(found["observer"]),
                        "of which signals disagree (observer)": sum(
                            d.signals_disagree for d in found["observer"]
                        ),
                        "false alarms (direct residual)": len(found["residual"]),
                    }
                )
                if (i, j, kind) == (2, 3, "state"):
                    external_torques(
                        estimates[j].t,
                        estimates[j].observer,
                        estimates[j].residual,
                        thresholds_of(estimates[j], calibrations, "observer"),
                        [(d.start, d.end) for d in found["observer"]],
                        folder / "real_lwr4_2_to_3.png",
                        "real LWR4+ run 3, model and state thresholds from run 2",
                    )
    return pd.DataFrame(rows)


def real_lwr4_rates(table: pd.DataFrame) -> pd.DataFrame:
    """False alarms per hour of monitored log, all directions together, per kind of thresholds."""
    totals = table.groupby("thresholds", sort=False).sum(numeric_only=True)
    hours = totals["monitored [s]"] / 3600.0
    return pd.DataFrame(
        {
            "thresholds": totals.index,
            "monitored [s]": totals["monitored [s]"].to_numpy(),
            "false alarms (observer)": totals["false alarms (observer)"].to_numpy(),
            "per hour (observer)": (totals["false alarms (observer)"] / hours).to_numpy(),
            "of which signals disagree (observer)": totals["of which signals disagree (observer)"].to_numpy(),
            "false alarms (direct residual)": totals["false alarms (direct residual)"].to_numpy(),
            "per hour (direct residual)": (totals["false alarms (direct residual)"] / hours).to_numpy(),
        }
    )


def crossed_table(folder: Path, chosen: MonitorSettings, duration: float, drift: float) -> pd.DataFrame:
    """The MuJoCo crossed scenario's figures per monitored log, kind of thresholds and estimator."""
    start = time.perf_counter()
    files = write_crossed_scenario(folder, duration=duration, drift=drift)
    print(f"crossed scenario simulated and identified in {time.perf_counter() - start:.0f} s ({folder})")
    robot = identified_robot(files.model)
    reference = [
        estimate_external_torques(robot, load_log(p, 7).to_measurement(), chosen) for p in files.calibration
    ]
    calibrations = {kind: calibrate(reference, replace(chosen, thresholds=kind)) for kind in THRESHOLD_KINDS}
    rows = []
    for name, log in files.monitored.items():
        estimates = estimate_external_torques(robot, load_log(log.log, 7).to_measurement(), chosen)
        contacts = pd.read_csv(log.contacts)
        truth = pd.read_parquet(log.truth)[[f"tau_ext{j}" for j in range(1, 8)]].to_numpy()
        seen = np.where(estimates.monitored[:, None], truth, 0.0)
        for kind in THRESHOLD_KINDS:
            found = detect(estimates, calibrations[kind], replace(chosen, thresholds=kind))
            for estimator in ESTIMATORS:
                thresholds = thresholds_of(estimates, calibrations[kind], estimator)
                detectable = detectable_contacts(
                    estimates.t, seen, contacts, thresholds, min_duration=chosen.min_duration
                )
                result = score_detections(found[estimator], contacts, detectable=detectable)
                rows.append(
                    {
                        "log": f"{name} (friction ×{log.friction_factor:g})",
                        "thresholds": kind,
                        "estimator": estimator,
                        "contacts ≥ 10 N": result.contacts,
                        "detected": result.detected,
                        "detectable": result.detectable,
                        "detectable missed": result.missed_detectable,
                        "false alarms": result.false_alarms,
                        "median delay [ms]": 1000 * result.median_delay,
                        "max delay [ms]": 1000 * float(result.delays.max()) if result.delays.size else np.nan,
                        "median threshold [N·m]": float(
                            np.mean(np.median(thresholds[estimates.monitored], axis=0))
                        ),
                    }
                )
    return pd.DataFrame(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--contact-free-s", type=float, default=600.0, help="contact-free motion before contacts (s)"
    )
    parser.add_argument("--contact-s", type=float, default=120.0, help="motion with contacts (s)")
    parser.add_argument(
        "--output", type=Path, default=Path("outputs/monitor_scenario"), help="scenario folder"
    )
    parser.add_argument("--crossed-s", type=float, default=60.0, help="each crossed MuJoCo log (s)")
    parser.add_argument("--drift", type=float, default=0.3, help="share by which the runs' friction differs")
    args = parser.parse_args()
    chosen = settings()
    step_us, vectorised_us = step_cost(build("robot", "kuka_lwr4"), chosen.observer_gain)
    print("## Observer cost (LWR4, 7 joints)\n")
    print(
        pd.DataFrame(
            [
                {"form": "step function (one sample)", "µs per sample": step_us},
                {"form": "vectorised over a 50 s log", "µs per sample": vectorised_us},
            ]
        ).to_markdown(index=False, floatfmt=".3g")
    )
    table = scenario_table(args.output, args.contact_free_s, args.contact_s, chosen)
    print("\n## Collision detection on the MuJoCo scenario\n")
    print(table.to_markdown(index=False, floatfmt=".3g"))
    row = real_lwr4_row(args.output, chosen)
    if row is not None:
        print(f"\n## Real LWR4+ (model and thresholds from runs 2 + 3, {chosen.thresholds} thresholds)\n")
        print(pd.DataFrame([row]).to_markdown(index=False))
    crossed = real_lwr4_crossed(args.output, chosen)
    if crossed is not None:
        print(
            "\n## Real LWR4+ crossed: model and thresholds from one run, another monitored (contact-free)\n"
        )
        print(crossed.to_markdown(index=False, floatfmt=".3g"))
        print("\n## Real LWR4+ crossed: false alarms per hour of monitored log, all directions\n")
        print(real_lwr4_rates(crossed).to_markdown(index=False, floatfmt=".3g"))
    table = crossed_table(args.output / "crossed", chosen, args.crossed_s, args.drift)
    print(
        f"\n## MuJoCo crossed: thresholds from an exciting and a moderate motion, friction ±{args.drift:g} "
        "between runs\n"
    )
    print(table.to_markdown(index=False, floatfmt=".3g"))


if __name__ == "__main__":
    main()
