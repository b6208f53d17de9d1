"""Every metric the tasks log, by its plain name's pattern: its unit and what it measures.

The manual's metric reference is generated from this catalogue (``docs/gen_metrics_reference.py``),
and the slow lesson test checks that every metric the lessons' runs write into ``metrics.json`` has an
entry here, so a new metric cannot reach MLflow undocumented. Where a name carries a joint (``<k>``), a
log (``<log>``), a tool, a roller or a classifier, the pattern matches any.

Examples
--------
>>> describe("rms_joint3").unit, describe("validation_rel_error_measurements_1").unit
('N·m', '1')
>>> describe("no_such_metric") is None
True
"""

from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class MetricFamily:
    """Metrics named alike: ``name`` as the manual writes it, its unit and meaning, the task logging it."""

    name: str
    unit: str
    meaning: str
    task: str

    @property
    def pattern(self) -> re.Pattern[str]:
        """The plain names this family covers: ``<…>`` in ``name`` stands for any non-empty part."""
        parts = re.split(r"<[^>]+>", self.name)
        return re.compile("^" + r"[\w.+-]+?".join(re.escape(p) for p in parts) + "$")


IDENTIFICATION = "identification"
EXCITATION = "excitation"
MONITOR = "monitor"
CHAIN = "paper_chain, painting, paper_table4_force"
TOOLS = "payload, table3_tools, tool_recognition_benchmark"
LIVE = "live_monitor"
SIM_ROBOT = "sim_robot"
LIVE_PAINTING = "live_painting"
SIM_PAINTING = "sim_painting_robot"

CATALOGUE: tuple[MetricFamily, ...] = (
    # identification: errors on the motions not fitted, then diagnostics
    MetricFamily("rms_mean", "N·m", "cross-validation RMS torque error, mean over joints", IDENTIFICATION),
    MetricFamily(
        "nrms_mean",
        "%",
        "the same error as a percentage of each joint's torque range, mean over joints",
        IDENTIFICATION,
    ),
    MetricFamily("rms_joint<k>", "N·m", "cross-validation RMS torque error of joint k", IDENTIFICATION),
    MetricFamily(
        "nrms_joint<k>", "%", "the same as a percentage of joint k's measured torque range", IDENTIFICATION
    ),
    MetricFamily("identification_rms_mean", "N·m", "the chain's identification stage: rms_mean", CHAIN),
    MetricFamily(
        "fit_rel_error", "1", "‖τ − τ̂‖/‖τ‖ on the identification logs' scored samples", IDENTIFICATION
    ),
    MetricFamily(
        "validation_rel_error",
        "1",
        "‖τ − τ̂‖/‖τ‖ on the validation logs, mean over logs (0.05 = 5 %)",
        IDENTIFICATION,
    ),
    MetricFamily("validation_rel_error_<log>", "1", "‖τ − τ̂‖/‖τ‖ on one validation log", IDENTIFICATION),
    MetricFamily(
        "base_parameter_error",
        "1",
        "‖β̂ − β‖/‖β‖ against the simulated robot's true base parameters",
        IDENTIFICATION,
    ),
    MetricFamily(
        "relative_error", "1", "‖β̂ − β‖/‖β‖ of one study's job (estimator benchmark)", "estimator_benchmark"
    ),
    MetricFamily(
        "fit_interval_coverage",
        "1",
        "share of the identification logs' torques inside their 95 % prediction interval",
        IDENTIFICATION,
    ),
    MetricFamily("validation_interval_coverage", "1", "the same on the validation logs", IDENTIFICATION),
    MetricFamily(
        "validation_coverage_joint<k>",
        "1",
        "joint k's interval coverage, validation logs pooled",
        IDENTIFICATION,
    ),
    MetricFamily(
        "validation_coverage_<log>_joint<k>",
        "1",
        "joint k's interval coverage on one validation log",
        IDENTIFICATION,
    ),
    MetricFamily(
        "validation_worst_joint_coverage",
        "1",
        "the lowest joint coverage over the validation logs",
        IDENTIFICATION,
    ),
    MetricFamily(
        "friction_drift",
        "1",
        "ρ: share of the friction torque by which the prediction intervals let friction differ on a new "
        "motion (measured between the identification logs, else the stated prior)",
        IDENTIFICATION,
    ),
    MetricFamily(
        "rows_near_rest_share",
        "1",
        "share of the identification rows where a joint stands, starts or stops (estimator.near_rest)",
        IDENTIFICATION,
    ),
    MetricFamily(
        "rows_near_rest_weight",
        "1",
        "mean weight of those rows, from their residual (1: as a moving row)",
        IDENTIFICATION,
    ),
    MetricFamily(
        "prediction_spread",
        "1",
        "predicted-torque spread across the joint limits, over the fit's residual σ (warned above 3)",
        IDENTIFICATION,
    ),
    MetricFamily("residual_std", "N·m", "standard deviation of the fit's torque residual", IDENTIFICATION),
    MetricFamily(
        "cond_W_b",
        "1",
        "condition number of the column-scaled base regressor",
        f"{IDENTIFICATION}, {EXCITATION}",
    ),
    MetricFamily("cond_W_b_scaled", "1", "the same on the optimisation grid, unit-norm columns", EXCITATION),
    MetricFamily(
        "smallest_relative_singular_value",
        "1",
        "the base regressor's smallest singular value over its largest",
        IDENTIFICATION,
    ),
    MetricFamily("identifiability_rank", "1", "rank of the base regressor", IDENTIFICATION),
    MetricFamily(
        "identifiability_rank_deficiency", "1", "base parameters the data cannot determine", IDENTIFICATION
    ),
    MetricFamily("still_joints", "1", "joints that never moved", IDENTIFICATION),
    MetricFamily("n_base_parameters", "1", "number of base parameters", IDENTIFICATION),
    MetricFamily("n_rows", "1", "regressor rows fitted (after decimation)", IDENTIFICATION),
    MetricFamily(
        "min_pseudo_inertia_eigenvalue",
        "kg·m²",
        "smallest pseudo-inertia eigenvalue of the reported standard parameters (< 0: no rigid body)",
        IDENTIFICATION,
    ),
    MetricFamily(
        "consistency_margin",
        "kg·m²",
        "largest ε with some standard set of these base parameters ⪰ ε (< 0: none is a rigid body)",
        IDENTIFICATION,
    ),
    MetricFamily(
        "prior_weight",
        "1",
        "the prior's weight chosen by cross-validation (estimator=sdp, weight: auto)",
        IDENTIFICATION,
    ),
    MetricFamily(
        "prior_dominated_parameters", "1", "base parameters that came mostly from the prior", IDENTIFICATION
    ),
    MetricFamily("cv_rel_error", "1", "held-out ‖τ − τ̂‖/‖τ‖ of the chosen prior weight", IDENTIFICATION),
    MetricFamily(
        "friction_cv_nrms", "%", "held-out NRMS of the friction law chosen by friction=auto", IDENTIFICATION
    ),
    MetricFamily("friction_candidates", "1", "friction candidates scored by friction=auto", IDENTIFICATION),
    MetricFamily(
        "rotor_inertia_columns",
        "1",
        "1 if the chosen model has reflected rotor-inertia columns",
        IDENTIFICATION,
    ),
    MetricFamily("solver_fallback", "1", "1 if the SDP fell back from CLARABEL to SCS", IDENTIFICATION),
    MetricFamily("fit_cpu_s", "s", "CPU time of the fit", IDENTIFICATION),
    MetricFamily("solve_time_s", "s", "wall time of the SDP solves", IDENTIFICATION),
    MetricFamily("stage_<name>_s", "s", "wall time of one stage of a task", "every task"),
    # exciting motions
    MetricFamily(
        "accepted", "1", "1 if the motion passed every check at 1 kHz (else written as rejected)", EXCITATION
    ),
    MetricFamily("cost", "1", "the criterion's value at the optimum", EXCITATION),
    MetricFamily("iterations", "1", "optimiser iterations", EXCITATION),
    MetricFamily("closest_self_m", "m", "closest approach of the robot to itself", EXCITATION),
    MetricFamily(
        "closest_world_m", "m", "closest approach of the robot to the world (table, obstacles)", EXCITATION
    ),
    MetricFamily(
        "worst_slack_<family>",
        "the family's unit",
        "smallest slack of one constraint family (position, velocity, acceleration, torque, world,"
        " self_collision) at 1 kHz",
        EXCITATION,
    ),
    MetricFamily(
        "worst_slack_at_verify_rate",
        "1",
        "smallest slack over every family at 1 kHz, relative to its limit",
        EXCITATION,
    ),
    MetricFamily("violated_families", "1", "constraint families violated at 1 kHz", EXCITATION),
    MetricFamily(
        "poorly_known_before",
        "1",
        "base parameters poorly known (a one-σ error moves the torque by over 1 % of its RMS) with what was"
        " known before the motion (task.known_logs, task.known_model; all of them when nothing)",
        EXCITATION,
    ),
    MetricFamily(
        "poorly_known_after", "1", "base parameters still poorly known after the designed motion", EXCITATION
    ),
    MetricFamily(
        "target_torque_std_before",
        "N·m",
        "expected std of the torque predicted along the target motions (task.targets), mean over targets"
        " and joints, with what was known before the motion",
        EXCITATION,
    ),
    MetricFamily(
        "target_torque_std_after",
        "N·m",
        "the same after the designed motion",
        EXCITATION,
    ),
    MetricFamily("optimisation_seconds", "s", "wall time of the optimisation", EXCITATION),
    MetricFamily("collision_check_seconds", "s", "wall time of the exact collision check", EXCITATION),
    MetricFamily(
        "duration_s_<criterion>",
        "s",
        "recommended duration by the knee rule (Fig. 5 study)",
        "duration_study",
    ),
    # monitoring
    MetricFamily("detections", "1", "contacts detected by the observer", MONITOR),
    MetricFamily("residual_detections", "1", "contacts detected by the direct residual", MONITOR),
    MetricFamily(
        "detections_signals_disagree",
        "1",
        "detections where the log's velocities contradict its positions (may be artefacts)",
        MONITOR,
    ),
    MetricFamily(
        "false_alarm_rate",
        "1/h",
        "alarms per hour on each calibration log with thresholds from the others",
        MONITOR,
    ),
    MetricFamily("monitored_alarm_rate", "1/h", "detections per hour of monitored log", MONITOR),
    MetricFamily("monitored_hours", "h", "length of the monitored logs", MONITOR),
    MetricFamily("observer_us_per_sample", "µs", "momentum observer's cost per sample", MONITOR),
    MetricFamily(
        "missed_contacts", "1", "true contacts of at least min_force not detected (simulations)", MONITOR
    ),
    MetricFamily("false_alarms", "1", "detections matching no true contact (simulations)", MONITOR),
    MetricFamily("contacts", "1", "true contacts of at least min_force (simulations)", MONITOR),
    MetricFamily(
        "detectable_contacts", "1", "true contacts whose torque some threshold can see (simulations)", MONITOR
    ),
    MetricFamily(
        "missed_detectable_contacts", "1", "detectable true contacts not detected (simulations)", MONITOR
    ),
    MetricFamily(
        "max_delay_ms",
        "ms",
        "largest delay from a true contact's onset to its detection (simulations)",
        MONITOR,
    ),
    MetricFamily(
        "residual_<score>",
        "1, ms",
        "the direct residual's contacts, missed contacts, false alarms and delays (simulations)",
        MONITOR,
    ),
    MetricFamily(
        "median_delay_ms",
        "ms",
        "median delay from a true contact's onset to its detection (simulations)",
        MONITOR,
    ),
    MetricFamily(
        "torque_rms_error",
        "N·m",
        "RMS error of the external-torque estimate against the truth (simulations)",
        MONITOR,
    ),
    # the live monitor and the simulated robot (ROS 2)
    MetricFamily("samples", "1", "joint states the live monitor estimated from", LIVE),
    MetricFamily("messages", "1", "JointState messages the live monitor received", LIVE),
    MetricFamily(
        "dropped_samples", "1", "samples the stream's stamps say are missing, and out-of-order ones", LIVE
    ),
    MetricFamily(
        "refused_messages", "1", "messages refused (joints missing, arrays, non-finite values)", LIVE
    ),
    MetricFamily("other_robot_messages", "1", "messages naming none of the robot's joints", LIVE),
    MetricFamily("out_of_order_samples", "1", "messages stamped at or before the last one", LIVE),
    MetricFamily("restarts", "1", "times the observer started anew (a stall, a publisher restarting)", LIVE),
    MetricFamily(
        "latency_<statistic>_ms",
        "ms",
        "a sample's publication to its estimates' publication: median, p99 (99th percentile), max",
        LIVE,
    ),
    MetricFamily("cpu_share", "1", "the live monitor's CPU time over its wall time (of one core)", LIVE),
    MetricFamily("duration_s", "s", "how long the live monitor ran", LIVE),
    MetricFamily(
        "start_to_first_estimate_s",
        "s",
        "from the process's start to the live monitor's first estimate",
        LIVE,
    ),
    MetricFamily("samples_published", "1", "joint states the simulated robot published", SIM_ROBOT),
    MetricFamily("pushes", "1", "forces the simulated robot was pushed by", SIM_ROBOT),
    MetricFamily(
        "publication_lag_<statistic>_ms",
        "ms",
        "how late the simulated robot published a sample after its due time: median, p99",
        SIM_ROBOT,
    ),
    MetricFamily(
        "late_publications", "1", "samples the simulated robot published more than a period late", SIM_ROBOT
    ),
    # painting through ROS 2 (live_painting, sim_painting_robot)
    MetricFamily("states", "1", "joint states the live painting controller took", LIVE_PAINTING),
    MetricFamily("commands", "1", "joint position commands it published", LIVE_PAINTING),
    MetricFamily(
        "commands_clamped", "1", "commands held to the joint, speed or acceleration limits", LIVE_PAINTING
    ),
    MetricFamily(
        "states_superseded",
        "1",
        "joint states estimated and guarded but not answered: a newer one had come (the loop caught up)",
        LIVE_PAINTING,
    ),
    MetricFamily(
        "missed_periods", "1", "control periods without a joint state (gaps in the stamps)", LIVE_PAINTING
    ),
    MetricFamily(
        "compute_<statistic>_ms", "ms", "the controller's own time per state: median, p99", LIVE_PAINTING
    ),
    MetricFamily("path_progress", "1", "share of the painting path commanded", LIVE_PAINTING),
    MetricFamily(
        "stopped_on_fault", "1", "1 if a guard stopped the run (stale states, force, contact)", LIVE_PAINTING
    ),
    MetricFamily("planning_s", "s", "time to plan the painting path", LIVE_PAINTING),
    MetricFamily("identification_s", "s", "time to identify the roller", LIVE_PAINTING),
    MetricFamily("start_s", "s", "from the controller's start to its first command", LIVE_PAINTING),
    MetricFamily(
        "samples_withheld", "1", "joint states the simulated robot withheld (a drill)", SIM_PAINTING
    ),
    MetricFamily("late_periods", "1", "periods the simulated robot stepped late", SIM_PAINTING),
    MetricFamily("commands_received", "1", "joint position commands the simulated robot took", SIM_PAINTING),
    MetricFamily("commands_refused", "1", "commands it refused (length, non-finite)", SIM_PAINTING),
    # painting and force control
    MetricFamily("coverage_<roller>_<model>_<feedback>", "1", "share of the planned area painted", CHAIN),
    MetricFamily(
        "rms_<roller>_<model>_<feedback>_<comparison>",
        "N",
        "RMS of the normal-force difference (estimated, measured, desired; Table IV)",
        CHAIN,
    ),
    MetricFamily("painted_area_m2_<roller>", "m²", "area of the optimised painting path", CHAIN),
    MetricFamily("duration_s_<roller>", "s", "duration of the optimised painting path", CHAIN),
    # tools and payloads
    MetricFamily("mass", "kg", "identified payload mass", TOOLS),
    MetricFamily("mass_error_pct", "%", "payload mass error against task.truth", TOOLS),
    MetricFamily("com_error_mm", "mm", "centre-of-mass error against task.truth", TOOLS),
    MetricFamily("com_<axis>", "m", "identified payload centre of mass in the flange frame", TOOLS),
    MetricFamily("recognition_confidence", "1", "1 − d₁/d₂ of the recognised tool", TOOLS),
    MetricFamily(
        "recognition_noise_distance",
        "σ",
        "distance of the payload to the nearest tool in the identification's standard deviations",
        TOOLS,
    ),
    MetricFamily("recognised_correct", "1", "1 if the recognised tool is task.truth", TOOLS),
    MetricFamily(
        "recognised_<tool>",
        "1",
        "1 for the recognised tool (recognised_unknown: far from every library tool)",
        TOOLS,
    ),
    MetricFamily("recognition_accuracy", "1", "share of trials recognised correctly (benchmark)", TOOLS),
    MetricFamily("mean_confidence", "1", "mean recognition confidence (benchmark)", TOOLS),
    MetricFamily(
        "min_heldout_noise_distance", "σ", "closest a held-out tool came to a library tool (benchmark)", TOOLS
    ),
    MetricFamily(
        "heldout_rejected_<classifier>",
        "1",
        "share of held-out tools recognised as unknown (benchmark)",
        TOOLS,
    ),
    MetricFamily("max_abs_mass_error_pct", "%", "largest tool mass error (Table III study)", TOOLS),
    MetricFamily(
        "gain_error_pct_<k>", "%", "drive gain k's error against the truth (simulations)", "drive_gains"
    ),
    MetricFamily("max_abs_gain_error_pct", "%", "largest drive-gain error (simulations)", "drive_gains"),
    MetricFamily("n_weak_gains", "1", "drive gains the payload cannot reveal (%σ above 1 %)", "drive_gains"),
    # logs written
    MetricFamily(
        "<role>_samples", "1", "samples of the identification or validation log written", "write_example_logs"
    ),
)
"""Every metric family, the specific before the general (the first whose pattern matches describes a name)."""


def describe(name: str) -> MetricFamily | None:
    """The family of a plain metric name, or None if the catalogue has none."""
    return next((family for family in CATALOGUE if family.pattern.match(name)), None)
