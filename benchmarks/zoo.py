"""The zoo: every data-driven default judged on arms nobody tuned it on, and on the real LWR4+ runs.

Members (:mod:`zoo_members`, beside this script): arms of ``example-robot-data`` with known truths
(MuJoCo rigid bodies with the paper's sign law or MuJoCo's own friction; geared arms with LuGre,
Stribeck, direction-asymmetric or sign friction at the motors, a coupled wrist; joint torque sensors
or motor encoders and currents; 100 Hz – 1 kHz; jittered stamps). Each is identified from its fit
log exactly as ``lwrlab task=identification plant=log`` identifies a user's logs (the command
line's config, with the option's overrides) and judged on its new motions (faster, slower,
point-to-point with rests) against the **noise-free true torque**, and on the arm standing still and
pushed (known contacts). The real LWR4+ runs (``../shared/data/kuka_lwr4_hw``, skipped without them)
are judged on their new-motion splits against their measured torques.

One table per choice (``--choice``): the default, the simplest option and the best option per
subject, with the ratios the defaults are held to (default ≤ 1.05 × simplest, ≤ 1.2 × best):

- ``friction``: the friction law and rotor-inertia columns (``friction=auto``) against fixed laws;
- ``intervals``: the 95 % prediction intervals' coverage on new motions (``statistics.friction_drift``);
- ``thresholds``: collision thresholds (``task.thresholds``): pushes at rest detected, false alarms;
- ``prior``: the SDP's weight toward the description's inertials (``estimator.weight: auto``);
- ``near_rest``: the rows near rest weighted by their residual (``estimator.near_rest: weighted``)
  against every row alike (``equal``);
- ``operation``: what a robot in operation logs, against the two fit logs: one exciting log, that log
  with a point-to-point cycle with rests (the cell's cycle) added, and the cycle alone, judged on the
  faster and slower new motions (the cycle is fit data here), with the error where they stand still;
- ``realisations``: one fit log recorded five times (the same motion and truth, the sensors' noise,
  quantisation and stamps drawn anew): the error on the new motions of each and the law each chooses;
- ``cutoff``: the processing's low-pass cut-offs (``measurement.processing.cutoff_hz`` and
  ``state_cutoff_hz``, both ``auto``) against one fixed filter on q, τ and W, and against the rows'
  automatic cut-off used on the states too (``auto, one filter``).

``--fit-logs fit p2p`` fits every member on one exciting log and its point-to-point cycle with rests,
as a robot in operation logs, and judges it on the faster and slower new motions (``friction``,
``intervals``, ``prior``, ``cutoff``, ``near_rest``; kept apart from the two fit logs' results).

Results are kept in ``outputs/zoo/results/<code hash>/`` (the hash of lwrlab/, plugins/ and conf/):
a table is rebuilt at once while the code is unchanged.

    .venv/bin/python benchmarks/zoo.py --choice friction            # one table (first run: minutes)
    .venv/bin/python benchmarks/zoo.py --choice friction --members panda_sign z1_sign
    .venv/bin/python benchmarks/zoo.py --all                        # every table
    .venv/bin/python benchmarks/zoo.py --choice friction --fit-logs fit p2p --no-real
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import pandas as pd

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from benchmarks.zoo_members import (  # noqa: E402
    CACHE,
    FIT,
    MEMBERS,
    NEW_MOTIONS,
    ZOO_VERSION,
    MemberLogs,
    build_member,
    noise_realisation,
    robot_settings,
)

REAL_LWR4 = REPOSITORY.parent / "shared" / "data" / "kuka_lwr4_hw"
REAL_SPLITS = {"2→3": (2, 3), "3→1": (3, 1), "3→2": (3, 2)}
"""The real LWR4+'s new-motion splits: fit run → validation run (run 3 is another, faster motion)."""
CHOICES = ("friction", "intervals", "thresholds", "prior", "cutoff", "near_rest", "operation", "realisations")
REALISATIONS = 5
"""``realisations``: how many times the fit log is recorded (the log itself and as many less one anew)."""
OWN_LOGS = ("thresholds", "operation", "realisations")
"""The choices that pick the logs they fit on themselves (``--fit-logs`` does not apply)."""
OPERATION_CHECKS = ("faster", "slower")
"""The new motions the ``operation`` choice judges on: the cycle (``p2p``) is fit data there."""
STANDING_SPEED = 0.01
"""rad/s: a sample of a new motion stands still where every joint's true speed is below this."""
PUSH_NOISE_FACTOR = 3.0
"""Pushes counted as detectable: a true external torque of at least this many times the observer's
RMS at rest without contact, on some joint."""


@dataclass(frozen=True)
class Option:
    """One setting of a choice: overrides of the command line, and the rotor-inertia columns."""

    label: str
    overrides: tuple[str, ...] = ()
    rotor: bool | None = None
    """The drive's ``rotor_inertia`` columns: on, off, or None: as the description says (auto)."""
    thresholds: str | None = None
    """``thresholds`` only: the monitor's ``task.thresholds``."""
    fit_logs: tuple[str, ...] | None = None
    """``operation``: the member's logs fitted on (judged on :data:`OPERATION_CHECKS`); ``thresholds``: the
    logs the model and its thresholds come from (None: the two fit logs)."""
    realisation: int | None = None
    """``realisations`` only: the fit log alone, recorded anew (≥ 1; 0: as built)."""


OPTIONS: dict[str, tuple[Option, ...]] = {
    "friction": (
        Option("sign", ("friction=sign",), rotor=False),
        Option("sign + rotor", ("friction=sign",), rotor=True),
        Option("smooth 0.01", ("friction=smooth", "friction.width=0.01"), rotor=False),
        Option("smooth 0.01 + rotor", ("friction=smooth", "friction.width=0.01"), rotor=True),
        Option("stribeck", ("friction=stribeck",)),
        Option("asymmetric", ("friction=asymmetric",)),
        Option("holding", ("friction=holding",)),
        Option("load", ("friction=load",)),
    ),
    "intervals": tuple(
        Option(f"drift {rho:g}", (f"statistics.friction_drift={rho:g}",)) for rho in (0.0, 0.1, 0.2, 0.3, 0.5)
    ),
    "thresholds": (
        Option("constant", thresholds="constant"),
        Option("state, at rest as moving", thresholds="state at rest as moving"),
        Option("state, the model's drift", thresholds="state with the model's drift"),
        Option("state, one fit log", thresholds="state", fit_logs=("fit",)),
    ),
    "prior": (
        Option("ols", ("estimator=ols",)),
        Option("sdp, no prior", ("estimator.regularization=none", "estimator.weight=0")),
        Option("sdp, weight 1e-4", ("estimator.weight=1e-4",)),
        Option("sdp, weight 1e-2", ("estimator.weight=1e-2",)),
        Option("sdp, one_se", ("estimator.selection=one_se",)),
    ),
    "cutoff": (
        *(
            Option(
                f"{hz:g} Hz",
                (f"measurement.processing.cutoff_hz={hz:g}", "measurement.processing.state_cutoff_hz=null"),
            )
            for hz in (2.0, 5.0, 10.0, 20.0)
        ),
        Option("auto, one filter", ("measurement.processing.state_cutoff_hz=null",)),
    ),
    "near_rest": (Option("equal", ("estimator.near_rest=equal",)),),
    "operation": (
        Option("two logs", fit_logs=FIT),
        Option("one log", fit_logs=("fit",)),
        Option("one log + cycle", fit_logs=("fit", "p2p")),
        Option("cycle alone", fit_logs=("p2p",)),
    ),
    "realisations": tuple(Option(f"record {k + 1}", realisation=k) for k in range(REALISATIONS)),
}
"""Each choice's options besides the default; the first is the simplest."""
DEFAULT = Option("default")


@dataclass
class Subject:
    """An arm judged by the zoo: a member (truth known) or the real LWR4+ (a split of its runs)."""

    name: str
    overrides: list[str]
    logs: MemberLogs | None = None
    drive: dict[str, Any] | None = None
    validation: tuple[str, ...] = NEW_MOTIONS
    notes: list[str] = field(default_factory=list)
    fit_logs: tuple[str, ...] = FIT
    """A member's logs it is fitted on (``--fit-logs``); results kept apart from the two fit logs'."""

    def with_option(self, option: Option, rest: bool = False) -> list[str]:
        """The command line's overrides for ``option`` (``rest``: the pushed log among the validation
        logs, for the monitor)."""
        overrides = list(self.overrides)
        if option.fit_logs is not None and self.logs is not None:
            overrides = self.logs.overrides(fit=option.fit_logs, validation=OPERATION_CHECKS)
        if option.realisation is not None and self.logs is not None:
            fit = noise_realisation(self.logs, option.realisation) if option.realisation else "fit"
            overrides = self.logs.overrides(fit=(fit,))
        if rest and self.logs is not None:
            overrides = self.logs.overrides(fit=option.fit_logs or FIT, validation=(*NEW_MOTIONS, "rest"))
        if option.rotor is not None:
            drive = {**(self.drive or {}), "rotor_inertia": option.rotor}
            overrides = [o for o in overrides if not o.startswith("robot.drive=")]
            overrides.append("robot.drive=" + json.dumps(drive).replace('"', ""))
        return overrides + list(option.overrides)

    def truth(self, name: str, n_joints: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The noise-free readings (M, N_J) of validation log ``name`` and where it truly stands still
        (M,), read at once (None: a real run)."""
        if self.logs is None:
            return None
        frame = self.logs.truth(name)
        speed = frame[[f"dq{j + 1}" for j in range(n_joints)]].to_numpy()
        return frame[[f"tau{j + 1}" for j in range(n_joints)]].to_numpy(), np.all(
            np.abs(speed) < STANDING_SPEED, axis=1
        )


def member_subject(logs: MemberLogs, fit: tuple[str, ...] = FIT) -> Subject:
    """A zoo member as a subject, fitted on its logs ``fit`` (judged on the new motions not among them)."""
    settings = robot_settings(logs.member)
    checks = tuple(name for name in NEW_MOTIONS if name not in fit)
    return Subject(
        logs.member.name,
        logs.overrides(fit=fit, validation=checks),
        logs,
        settings.get("drive"),
        checks,
        fit_logs=fit,
    )


def real_subjects() -> list[Subject]:
    """The real LWR4+'s new-motion splits (none without ``../shared``)."""
    if not (REAL_LWR4 / "kuka_lwr4.urdf").is_file():
        return []
    base = [
        "robot=urdf",
        f"robot.path={REAL_LWR4 / 'kuka_lwr4.urdf'}",
        "task=identification",
        "plant=log",
        "tracking=none",
        "data.column_map={t: times, q: positions, dq: velocities, tau: torques}",
    ]
    return [
        Subject(
            f"lwr4+ {name}",
            [
                *base,
                f"data.paths=[{REAL_LWR4 / f'measurements_{fit}.npz'}]",
                f"data.validation_paths=[{REAL_LWR4 / f'measurements_{check}.npz'}]",
            ],
            validation=(f"measurements_{check}",),
        )
        for name, (fit, check) in REAL_SPLITS.items()
    ]


def compose(overrides: list[str]) -> Any:
    """The repository's config with ``overrides``, as the command line composes it."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    import lwrlab.conf  # noqa: F401  (registers the schemas the config tree links)

    with initialize_config_dir(config_dir=str(REPOSITORY / "conf"), version_base="1.3"):
        return hydra_compose("config", overrides=overrides)


REPORTS: dict[tuple[str, ...], tuple[Any, Any]] = {}
"""The identifications of this process by their overrides (the thresholds' options share one)."""


def identify(overrides: list[str]) -> tuple[Any, Any]:
    """The configuration and lwrlab's identification report for ``overrides``."""
    from lwrlab.pipeline.identification import identify_configured

    key = tuple(overrides)
    if key not in REPORTS:
        cfg = compose(overrides)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            REPORTS.clear()  # one at a time: a report holds every log's predictions
            REPORTS[key] = (cfg, identify_configured(cfg))
    return REPORTS[key]


def prediction_scores(subject: Subject, report: Any) -> dict[str, Any]:
    """Validation error against the truth (the measured torque on a real run), the noise floor, the
    95 % interval's coverage (overall and worst joint, of the measured torques, as the product
    reports it), on the subject's new motions."""
    errors, floors, inside, counted = [], [], None, None
    squares = {"standing": 0.0, "moving": 0.0, "standing floor": 0.0}  # Σ error², over every log
    torques = {"standing": 0.0, "moving": 0.0}  # Σ true torque²
    n = report.robot.n_joints
    for p in report.validation_predictions:
        if p.name not in subject.validation:
            continue
        scored = p.scored
        known = subject.truth(p.name, n)
        truth, still = (None, None) if known is None else known
        reference = p.measured if truth is None else truth
        errors.append(np.linalg.norm((reference - p.predicted)[scored]) / np.linalg.norm(reference[scored]))
        if truth is not None:
            floors.append(np.linalg.norm((p.measured - truth)[scored]) / np.linalg.norm(truth[scored]))
            for part, rows in (("standing", scored & still), ("moving", scored & ~still)):
                squares[part] += float(np.sum((truth - p.predicted)[rows] ** 2))
                torques[part] += float(np.sum(truth[rows] ** 2))
            squares["standing floor"] += float(np.sum((p.measured - truth)[scored & still] ** 2))
        if p.half_width is not None:
            hits = (np.abs(p.measured - p.predicted) <= p.half_width)[scored]
            inside = hits.sum(axis=0) if inside is None else inside + hits.sum(axis=0)
            counted = scored.sum() if counted is None else counted + scored.sum()
    row: dict[str, Any] = {"error %": 100 * float(np.mean(errors))}
    if floors:
        row["noise floor %"] = 100 * float(np.mean(floors))
    if torques["standing"] > 0 and torques["moving"] > 0:  # each part relative to its own torque
        row["standing error %"] = 100 * float(np.sqrt(squares["standing"] / torques["standing"]))
        row["moving error %"] = 100 * float(np.sqrt(squares["moving"] / torques["moving"]))
        row["standing noise floor %"] = 100 * float(np.sqrt(squares["standing floor"] / torques["standing"]))
    if inside is not None and counted:
        joints = inside / counted
        row["coverage %"] = 100 * float(joints.mean())
        row["worst joint coverage %"] = 100 * float(joints.min())
        row["worst joint"] = int(np.argmin(joints) + 1)
    choice = report.friction_choice
    row["law"] = choice.candidate.label if choice is not None else report.robot.friction_law.name
    drift = report.metrics.get("friction_drift")
    if drift is not None:
        row["drift"] = float(drift)
    return row


def monitor_scores(subject: Subject, cfg: Any, report: Any, kind: str) -> dict[str, Any]:
    """Collision detection with the identified model and ``kind`` thresholds calibrated on the fit
    logs: pushes at rest detected (of those ≥ :data:`PUSH_NOISE_FACTOR` × the observer's RMS at rest),
    false alarms on the contact-free new motions (per hour; those where the log's velocities
    contradict its positions counted apart too)."""
    from dataclasses import replace as replace_settings

    from benchmarks.monitor import settings as monitor_settings
    from lwrlab.io.artifacts import save_identified_model
    from lwrlab.monitoring.estimates import calibrate, detect, estimate_external_torques, thresholds_of
    from lwrlab.monitoring.scoring import score_detections
    from lwrlab.pipeline.build import build
    from lwrlab.pipeline.config_nodes import resolved_mapping

    settings = replace_settings(monitor_settings(), thresholds="state" if kind.startswith("state") else kind)
    if kind == "state at rest as moving":
        settings = replace_settings(settings, rest_thresholds="moving")
    if kind == "state with the model's drift":  # what its identification measured between its logs
        settings = replace_settings(settings, friction_drift=float(report.identified.friction_drift))

    def estimate(measurement: Any) -> Any:
        return estimate_external_torques(robot, measurement, settings)

    with tempfile.TemporaryDirectory() as folder:
        path = save_identified_model(
            report.identified, resolved_mapping(cfg.robot, "robot"), Path(folder) / "identified_model.yaml"
        )
        robot = build("robot", "identified", source=str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = [estimate(m) for m in report.measurements]
        calibrations = calibrate(fit, settings)
        monitored = {m.name: m for m in report.validation_measurements}
        row: dict[str, Any] = {}
        alarms, disagreeing, hours = 0, 0, 0.0
        for name in subject.validation:
            estimates = estimate(monitored[name])
            found = detect(estimates, calibrations, settings)["observer"]
            alarms += len(found)
            disagreeing += sum(d.signals_disagree for d in found)
            hours += estimates.monitored_hours
        row["false alarms"] = alarms
        row["where the log contradicts itself"] = disagreeing
        row["false alarms per hour"] = alarms / hours if hours else float("nan")
        if subject.logs is None or "rest" not in monitored:
            return row
        estimates = estimate(monitored["rest"])
        found = detect(estimates, calibrations, settings)["observer"]
        contacts = subject.logs.contacts
        truth = subject.logs.truth("rest")
        external = truth[[f"tau_ext{j + 1}" for j in range(robot.n_joints)]].to_numpy()
        quiet = estimates.monitored & np.all(np.abs(external) == 0.0, axis=1)
        for start, end in zip(contacts["start"], contacts["end"], strict=True):
            quiet &= (estimates.t < start - 0.5) | (estimates.t > end + 1.0)
        true_speed = truth[[f"dq{j + 1}" for j in range(robot.n_joints)]].to_numpy()
        at_rest = quiet & np.all(np.abs(true_speed) < 0.01, axis=1)
        noise = np.sqrt(np.mean(estimates.observer[at_rest] ** 2, axis=0))
        peaks = np.array(
            [
                np.abs(external[(estimates.t >= s) & (estimates.t <= e)]).max(axis=0)
                for s, e in zip(contacts["start"], contacts["end"], strict=True)
            ]
        )
        detectable = np.any(peaks >= PUSH_NOISE_FACTOR * noise, axis=1)
        score = score_detections(found, contacts, min_force=0.0, detectable=detectable)
        rest_thresholds = thresholds_of(estimates, calibrations, "observer")[at_rest].mean(axis=0)
        row |= {
            "pushes": len(contacts),
            "pushes ≥ 3× noise": int(detectable.sum()),
            "detected": int((detectable & score.detected_mask).sum()),
            "detected %": 100 * float((detectable & score.detected_mask).sum() / max(detectable.sum(), 1)),
            "false alarms at rest": score.false_alarms,
            "noise at rest N·m": noise.tolist(),
            "threshold at rest N·m": rest_thresholds.tolist(),
        }
        return row


def code_hash() -> str:
    """A hash of what the results depend on: lwrlab/, plugins/, conf/ and the zoo's version."""
    digest = hashlib.sha256(f"zoo {ZOO_VERSION}".encode())
    for folder in ("lwrlab", "plugins", "conf"):
        for path in sorted((REPOSITORY / folder).rglob("*")):
            if path.suffix in (".py", ".yaml") and "__pycache__" not in path.parts:
                digest.update(str(path.relative_to(REPOSITORY)).encode())
                digest.update(path.read_bytes())
    for name in ("zoo.py", "zoo_members.py"):
        digest.update((REPOSITORY / "benchmarks" / name).read_bytes())
    return digest.hexdigest()[:12]


def evaluate(subject: Subject, choice: str, option: Option, store: Path) -> dict[str, Any]:
    """One subject under one option of ``choice`` (kept in ``store``)."""
    scenario = "" if subject.fit_logs == FIT else "__fit-" + "-".join(subject.fit_logs)
    key = f"{subject.name}{scenario}__{choice}__{option.label}".replace(" ", "_").replace("/", "-")
    path = store / f"{key}.json"
    if path.is_file():
        return dict(json.loads(path.read_text()))
    started = time.process_time()
    if choice == "thresholds":
        kind = option.thresholds or "state"
        cfg, report = identify(subject.with_option(option, rest=subject.logs is not None))
        row = {**prediction_scores(subject, report), **monitor_scores(subject, cfg, report, kind)}
    else:
        _, report = identify(subject.with_option(option))
        row = prediction_scores(subject, report)
    row["cpu s"] = round(time.process_time() - started, 1)
    store.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(row))
    return row


def _ratio(a: float, b: float) -> float:
    return float(a / b) if b > 0 else float("nan")


def error_table(rows: dict[str, dict[str, dict[str, Any]]], choice: str) -> pd.DataFrame:
    """Per subject: the default's error, the simplest option's and the best one's (% of the true torque
    on new motions; measured on the real runs), and the ratios the default is held to."""
    simplest = OPTIONS[choice][0].label
    out = []
    for subject, results in rows.items():
        default = results[DEFAULT.label]
        best = min(results, key=lambda label: results[label]["error %"])
        entry = {
            "subject": subject,
            "default %": default["error %"],
            "simplest %": results[simplest]["error %"],
            "best %": results[best]["error %"],
            "best option": best,
            "default / simplest": _ratio(default["error %"], results[simplest]["error %"]),
            "default / best": _ratio(default["error %"], results[best]["error %"]),
            "noise floor %": default.get("noise floor %", float("nan")),
        }
        if choice == "friction":
            entry["chosen"] = default["law"]
        out.append(entry)
    return pd.DataFrame(out)


def coverage_table(rows: dict[str, dict[str, dict[str, Any]]]) -> pd.DataFrame:
    """Per subject: the 95 % intervals' coverage of the new motions, overall and on the worst joint, by
    default, with no friction drift (the simplest) and with the drift closest to 95 % (the best)."""
    simplest = OPTIONS["intervals"][0].label
    out = []
    for subject, results in rows.items():
        default = results[DEFAULT.label]
        best = min(
            results,
            key=lambda label: (
                results[label]["worst joint coverage %"] < 88.0,
                abs(results[label]["coverage %"] - 95.0),
            ),
        )
        out.append(
            {
                "subject": subject,
                "default %": default["coverage %"],
                "default worst joint %": default["worst joint coverage %"],
                "drift": default.get("drift", float("nan")),
                "simplest %": results[simplest]["coverage %"],
                "simplest worst joint %": results[simplest]["worst joint coverage %"],
                "best option": best,
                "best %": results[best]["coverage %"],
                "best worst joint %": results[best]["worst joint coverage %"],
            }
        )
    return pd.DataFrame(out)


def threshold_table(rows: dict[str, dict[str, dict[str, Any]]]) -> pd.DataFrame:
    """Per subject and kind of thresholds: pushes at rest detected (of those ≥ 3 × the noise at rest),
    false alarms on the contact-free new motions (and those where the log contradicts itself), the
    thresholds at rest beside the noise there."""
    out = []
    for subject, results in rows.items():
        for label, result in results.items():
            out.append(
                {
                    "subject": subject,
                    "thresholds": "state (default)" if label == DEFAULT.label else label,
                    "detected": f"{result['detected']} / {result['pushes ≥ 3× noise']}"
                    if "detected" in result
                    else "",
                    "detected %": result.get("detected %", float("nan")),
                    "false alarms, new motions": result["false alarms"],
                    "of which the log contradicts itself": result["where the log contradicts itself"],
                    "per hour": result["false alarms per hour"],
                    "false alarms at rest": result.get("false alarms at rest", ""),
                    "threshold at rest / noise": _rest_ratio(result),
                }
            )
    return pd.DataFrame(out)


def operation_table(rows: dict[str, dict[str, dict[str, Any]]]) -> pd.DataFrame:
    """Per member: the error on the faster and slower new motions (% of the true torque) fitted on the
    two fit logs, on one, on one with the cycle added, on the cycle alone; what adding the cycle does;
    the error where the new motions stand still beside the moving error and the noise floor there
    (one log); the 95 % intervals' coverage with one log and with the cycle added."""
    out = []
    for subject, results in rows.items():
        one, added = results["one log"], results["one log + cycle"]
        out.append(
            {
                "subject": subject,
                "two logs %": results["two logs"]["error %"],
                "one log %": one["error %"],
                "one log + cycle %": added["error %"],
                "cycle alone %": results["cycle alone"]["error %"],
                "+ cycle / one log": _ratio(added["error %"], one["error %"]),
                "standing / moving": _ratio(
                    one.get("standing error %", np.nan), one.get("moving error %", np.nan)
                ),
                "standing / its noise floor": _ratio(
                    one.get("standing error %", np.nan), one.get("standing noise floor %", np.nan)
                ),
                "coverage one log %": one.get("coverage %", np.nan),
                "worst joint %": one.get("worst joint coverage %", np.nan),
                "coverage + cycle %": added.get("coverage %", np.nan),
                "worst joint + cycle %": added.get("worst joint coverage %", np.nan),
            }
        )
    return pd.DataFrame(out)


def realisation_table(rows: dict[str, dict[str, dict[str, Any]]]) -> pd.DataFrame:
    """Per member: the error on the new motions (% of the true torque) of the model fitted on each
    record of one fit log, the median, the worst over the median, and the laws chosen (by name: their
    fitted widths and speeds may differ)."""
    out = []
    for subject, results in rows.items():
        errors = np.array([result["error %"] for result in results.values()])
        laws = [re.sub(r" \([^)]*\)", "", str(result["law"])) for result in results.values()]  # by name
        distinct = list(dict.fromkeys(laws))  # in the order first chosen
        median = float(np.median(errors))
        out.append(
            {
                "subject": subject,
                "errors %": " / ".join(f"{e:.3g}" for e in errors),
                "median %": median,
                "worst / median": _ratio(float(errors.max()), median),
                "laws": " / ".join(distinct),
                "records per law": " / ".join(str(laws.count(law)) for law in distinct),
            }
        )
    return pd.DataFrame(out)


def _rest_ratio(result: dict[str, Any]) -> str:
    if "threshold at rest N·m" not in result:
        return ""
    ratio = np.asarray(result["threshold at rest N·m"]) / np.maximum(result["noise at rest N·m"], 1e-9)
    return f"{ratio.min():.1f}–{ratio.max():.1f}"


def table(choice: str, subjects: list[Subject], store: Path) -> pd.DataFrame:
    """Evaluate every subject under the default and every option of ``choice``; its table."""
    rows: dict[str, dict[str, dict[str, Any]]] = {}
    options = [DEFAULT, *OPTIONS[choice]]
    if choice == "thresholds":
        options = [*OPTIONS[choice], DEFAULT]
    if choice in ("operation", "realisations"):  # every option names its fit logs; members only
        options = list(OPTIONS[choice])
        subjects = [subject for subject in subjects if subject.logs is not None]
    for subject in subjects:
        rows[subject.name] = {}
        for option in options:
            started = time.perf_counter()
            result = evaluate(subject, choice, option, store)
            rows[subject.name][option.label] = result
            shown = {k: v for k, v in result.items() if isinstance(v, int | float | str)}
            print(
                f"  {subject.name:18s} {option.label:22s} {time.perf_counter() - started:5.1f} s  "
                + "  ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in shown.items()),
                flush=True,
            )
    if choice == "intervals":
        return coverage_table(rows)
    if choice == "thresholds":
        return threshold_table(rows)
    if choice == "operation":
        return operation_table(rows)
    if choice == "realisations":
        return realisation_table(rows)
    return error_table(rows, choice)


def subjects(names: list[str] | None, seed: int, real: bool, fit: tuple[str, ...] = FIT) -> list[Subject]:
    """The members (built or read back), each fitted on its logs ``fit``, and the real runs' splits
    (each fitted on one run)."""
    chosen = []
    for name in names or list(MEMBERS):
        started = time.perf_counter()
        logs = build_member(MEMBERS[name], seed)
        print(f"{name}: {logs.folder} ({time.perf_counter() - started:.1f} s)", flush=True)
        chosen.append(member_subject(logs, fit))
    return chosen + (real_subjects() if real else [])


def members_table() -> pd.DataFrame:
    """The members as data: arm, engine, friction, sensors, rate, what is special."""
    rows = []
    for member in MEMBERS.values():
        truth, sensors = member.truth, member.sensors
        engine = "MuJoCo, PD" if truth.engine == "mujoco" else f"gears {truth.gear_ratio:g}"
        if truth.coupling:
            engine += ", coupled wrist"
        law = {"mujoco": "MuJoCo frictionloss + damping"}.get(truth.law, truth.law)
        if truth.load_factor:
            law += f", Coulomb + {truth.load_factor:g} × load"
        effort = "currents" if sensors.effort == "current" else "torques"
        measured = "joint torque sensors" if sensors.side == "joint" else f"motor encoders, {effort}"
        rows.append(
            {
                "member": member.name,
                "arm": member.robot,
                "engine": engine,
                "friction": law,
                "sensors": measured,
                "rate [Hz]": f"{sensors.rate_hz:g}" + (", jittered" if sensors.jitter else ""),
                "log": sensors.log_format,
                "what is special": member.note,
            }
        )
    return pd.DataFrame(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--choice", nargs="*", choices=CHOICES, default=[])
    parser.add_argument("--all", action="store_true", help="every choice")
    parser.add_argument("--members", nargs="*", help=f"some members only (default all: {', '.join(MEMBERS)})")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--fit-logs",
        nargs="+",
        choices=(*FIT, "p2p"),
        default=list(FIT),
        help="the members' logs fitted on (default: the two exciting logs; 'fit p2p': one exciting log and "
        "the point-to-point cycle, as a robot in operation logs); judged on the new motions not among them",
    )
    parser.add_argument("--no-real", action="store_true", help="leave the real LWR4+ runs out")
    parser.add_argument("--list", action="store_true", help="print the members' table and stop")
    args = parser.parse_args()
    if args.list:
        print("## members\n")
        print(members_table().to_markdown(index=False))
        return
    choices = list(CHOICES) if args.all else args.choice
    if not choices:
        parser.error("give --choice …, --all or --list")
    fit = tuple(args.fit_logs)
    scenario = "" if fit == FIT else f" (fitted on {' + '.join(fit)})"
    if scenario and set(choices) & set(OWN_LOGS):
        parser.error(
            f"--fit-logs does not apply to {sorted(set(choices) & set(OWN_LOGS))}: they choose their own logs"
        )
    chosen = subjects(args.members, args.seed, not args.no_real, fit)
    store = CACHE / "results" / code_hash()
    print(f"results kept in {store}", flush=True)
    for choice in choices:
        print(f"\n{choice}:", flush=True)
        result = table(choice, chosen, store)
        print(f"\n## {choice}{scenario}\n")
        print(result.to_markdown(index=False, floatfmt=".3g"))


if __name__ == "__main__":
    main()
