"""Tool stages: identify a tool's parameters by eq. (7) and recognise it (Table III); benchmark recognition.

Both stages run the same chain for every tool: the simulated robot executes an exciting motion
unloaded and a tool motion carrying the tool, the measurements are processed as in §III.E, the
tool's 10 parameters are identified (:mod:`lwrlab.identification.payload`) and a classifier picks
the library tool they belong to (:mod:`lwrlab.tools.recognition`). The functions that compute
return plain values; ``run_*`` build the objects from the config and write the tables and figures
(the tracking callback logs the folder to MLflow).
"""

from __future__ import annotations

import copy
import json
import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.errors import ConfigError
from lwrlab.figures.tools import confusion_matrices, relative_std_bars
from lwrlab.identification.context import row_joints
from lwrlab.identification.least_squares import grouped_least_squares
from lwrlab.identification.payload import (
    PayloadEstimate,
    identify_payload,
    identify_payload_only,
    tool_columns,
)
from lwrlab.model.inertia import LINK_PARAMETER_NAMES
from lwrlab.model.payload import flange_placement, frame_change_matrix
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.tool_library import load_library
from lwrlab.plants.core import Plant
from lwrlab.reference import paper_results
from lwrlab.signal.processing import process
from lwrlab.tools.excitation import select_tool_motion
from lwrlab.tools.library import PAPER_TOOLS, ToolLibrary
from lwrlab.tools.model import GEOMETRY_NAMES, Tool
from lwrlab.tools.recognition import Recognition, ToolClassifier
from lwrlab.trajectory.core import Trajectory, check_limits

log = logging.getLogger(__name__)

METHODS = ("joint", "payload_only")
"""``joint``: eq. (7), robot and tool together; ``payload_only``: the robot first (unloaded motion), then the tool."""


@dataclass(frozen=True)
class ToolData:
    """One processed measurement as eq. (7) uses it (rows sample-major)."""

    w_base: np.ndarray
    """(rows, N_B) base regressor of the robot."""
    w_tool: np.ndarray
    """(rows, 10) columns of the flange-carrying segment (its joint frame)."""
    tau: np.ndarray
    """(rows,) processed joint torques (N·m)."""


@dataclass(frozen=True)
class ToolBench:
    """What every tool identification on one robot shares."""

    robot: RobotModel
    base: BaseParameters
    flange_to_joint: np.ndarray
    """T with ``φ_joint = T·φ_flange`` (10×10)."""
    tool_joint: int
    """The joint carrying the flange (1-based)."""
    processing: dict[str, Any]

    @classmethod
    def for_robot(cls, robot: RobotModel, processing: dict[str, Any] | None = None) -> ToolBench:
        joint, placement = flange_placement(robot)
        return cls(
            robot,
            compute_base_parameters(robot),
            frame_change_matrix(placement.rotation, placement.translation),
            joint,
            dict(processing or {}),
        )

    def data(self, plant: Plant, motion: Trajectory) -> ToolData:
        """Execute ``motion`` on ``plant`` and build the regressors from the processed measurement."""
        measurement = plant.measure(motion)
        processed = process(measurement.t, measurement.q, measurement.tau, measurement.dq, **self.processing)
        w, tau = processed.rows(lambda q, dq, ddq: regressor(self.robot, q, dq, ddq))
        return ToolData(
            self.base.base_regressor(w), w[:, tool_columns(self.robot.n_links, self.tool_joint)], tau
        )

    def truth_in_joint_frame(self, tool: Tool) -> np.ndarray:
        """The tool's true parameters in the flange-carrying joint's frame (Table III's frame)."""
        return self.flange_to_joint @ tool.parameters


def identify_tool(
    bench: ToolBench,
    unloaded: ToolData,
    loaded: ToolData,
    method: str = "joint",
    weighted: bool = True,
    consistent: bool = False,
) -> PayloadEstimate:
    """The tool's parameters from an unloaded and a loaded measurement, by ``method`` (see :data:`METHODS`)."""
    n = bench.robot.n_joints
    if method == "joint":
        return identify_payload(
            unloaded.w_base,
            unloaded.tau,
            loaded.w_base,
            loaded.w_tool,
            loaded.tau,
            bench.flange_to_joint,
            n,
            weighted,
            consistent,
        )
    if method == "payload_only":
        robot_base = grouped_least_squares(
            unloaded.w_base, unloaded.tau, row_joints(unloaded.tau.size, n) if weighted else None
        ).phi
        return identify_tool_given_robot(bench, loaded, robot_base, weighted, consistent)
    raise ValueError(f"unknown tool identification method {method!r}; valid: {list(METHODS)}")


def identify_tool_given_robot(
    bench: ToolBench,
    loaded: ToolData,
    robot_base: np.ndarray,
    weighted: bool = True,
    consistent: bool = False,
) -> PayloadEstimate:
    """The tool's parameters from a loaded measurement, the robot's base parameters ``robot_base`` known."""
    return identify_payload_only(
        loaded.w_base,
        robot_base,
        loaded.w_tool,
        loaded.tau,
        bench.flange_to_joint,
        bench.robot.n_joints,
        weighted,
        consistent,
    )


def _motion(source: Any, robot: RobotModel, rate_hz: float, what: str) -> Trajectory:
    motion = source.sample(robot, rate_hz)
    check_limits(motion, robot, torque=robot.inverse_dynamics(motion.q, motion.dq, motion.ddq), what=what)
    return motion


def tool_motion(
    source: Callable[..., Any], count: int, robot: RobotModel, rate_hz: float
) -> tuple[Trajectory, pd.DataFrame]:
    """The loaded motion: the best of ``count`` seeded motions by the tool criterion.

    ``source`` builds a motion source from a ``seed`` keyword (a partial motion plugin whose own
    ``seed`` is the first candidate's). Returns the motion and a table of every candidate's seed and
    criterion value.
    """
    keywords = getattr(source, "keywords", {})
    if "seed" not in keywords:  # the first candidate's seed is the YAML's, never a silent 0
        raise ConfigError("`task.tool_motion` gives no `seed`: the first candidate's seed (e.g. `seed: 100`)")
    first_seed = int(keywords["seed"])
    candidates = [
        _motion(source(seed=first_seed + k), robot, rate_hz, "tool motion") for k in range(int(count))
    ]
    best, values = select_tool_motion(robot, candidates)
    table = pd.DataFrame(
        {"seed": first_seed + np.arange(count), "tool_logdet": values, "chosen": np.arange(count) == best}
    )
    log.info(
        "tool motion: seed %d of %d candidates (tool log-det criterion %.3f)",
        first_seed + best,
        count,
        values[best],
    )
    return candidates[best], table


def _required_motion(source: Callable[..., Any] | None) -> Callable[..., Any]:
    if source is None:
        raise ValueError(
            "the tool stages need `task.tool_motion`: a partial motion plugin (`_partial_: true`) with a seed"
        )
    return source


def _setup(
    cfg: Any, library_names: Sequence[str] | None, motion_source: Callable[..., Any], candidates: int
) -> tuple[RobotModel, ToolBench, Any, Trajectory, Trajectory, pd.DataFrame, ToolLibrary]:
    """Robot, bench, unloaded plant factory, unloaded and tool motions, library: what both stages need."""
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    if getattr(getattr(instantiate(cfg.plant), "func", None), "recorded", False):  # a plant that replays logs
        raise ConfigError(
            "the simulated tool stages (Table III, recognition benchmark) attach tools to a simulated robot; "
            "for a payload in recorded logs use task=payload plant=log 'task.unloaded_paths=[…]' 'task.loaded_paths=[…]'"
        )
    robot = instantiate(cfg.robot)
    rate = float(cfg.measurement.rate_hz)
    bench = ToolBench.for_robot(robot, OmegaConf.to_container(cfg.measurement.processing, resolve=True))
    unloaded_motion = _motion(instantiate(cfg.trajectory), robot, rate, "exciting motion (unloaded)")
    loaded_motion, candidate_table = tool_motion(motion_source, candidates, robot, rate)
    library = load_library(list(library_names) if library_names else None)

    def plant_for(seed: int) -> Any:
        return instantiate(cfg.plant, seed=seed, tool=None, show_progress=False)(robot=robot)

    return robot, bench, plant_for, unloaded_motion, loaded_motion, candidate_table, library


# --- Table III -------------------------------------------------------------------------------------


def table3_rows(tool: Tool, estimate: PayloadEstimate, truth: np.ndarray) -> pd.DataFrame:
    """Table III rows of one tool: Φ and %σ per parameter (joint frame), truth, flange-frame values, paper."""
    paper = paper_results()["table3_tool_parameters"]
    paper_key = {"large_roller": 0, "small_roller": 2}.get(tool.name)
    rows = pd.DataFrame(
        {
            "tool": tool.name,
            "parameter": LINK_PARAMETER_NAMES,
            "phi": estimate.phi,
            "relative_std": estimate.relative_std,
            "truth": truth,
            "phi_flange": estimate.phi_flange,
            "truth_flange": tool.parameters,
            "paper_phi": [
                paper[p][paper_key] if paper_key is not None else np.nan for p in LINK_PARAMETER_NAMES
            ],
            "paper_relative_std": [
                paper[p][paper_key + 1] if paper_key is not None else np.nan for p in LINK_PARAMETER_NAMES
            ],
        }
    )
    return rows


def run_table3_tools(
    cfg: Any,
    output_dir: Path,
    tools: Sequence[str] = PAPER_TOOLS,
    library: Sequence[str] | None = None,
    method: str = "joint",
    weighted: bool = True,
    consistent: bool = False,
    tool_motion: Callable[..., Any] | None = None,
    tool_motion_candidates: int = 8,
) -> dict[str, float]:
    """Task ``table3_tools``: identify each tool of ``tools`` by eq. (7) and recognise it (Table III).

    The keyword arguments are the task config's (conf/task/table3_tools.yaml): ``tools`` to identify,
    the ``library`` of the look-up (None: all of conf/tool/), the identification ``method``
    (:data:`METHODS`), ``weighted`` and ``consistent`` (see :func:`identify_tool`), and the loaded
    motion: the best of ``tool_motion_candidates`` seeds of the partial motion plugin ``tool_motion``.

    Writes ``table3_tools.csv`` with columns ``tool, parameter`` (M … YZ), ``phi`` and
    ``relative_std`` (identified value in the flange-carrying joint's frame, frame 7 as in the paper;
    SI units; %σ), ``truth`` (the simulated tool, same frame), ``phi_flange`` / ``truth_flange`` (the
    same in the flange frame), ``paper_phi`` / ``paper_relative_std`` (Table III, paper rollers only);
    ``tool_recognition.csv`` (tool, recognised, confidence, geometry, mass error), ``tool_motion.csv``
    (candidate seeds and their tool criterion), ``table3_relative_std.png`` and ``summary.md``.
    """
    from hydra.utils import instantiate

    output_dir.mkdir(parents=True, exist_ok=True)
    robot, bench, plant_for, unloaded_motion, loaded_motion, candidates, library = _setup(
        cfg, library, _required_motion(tool_motion), tool_motion_candidates
    )
    classifier: ToolClassifier = instantiate(cfg.classifier).fit(library)
    plant = plant_for(int(cfg.seed))
    unloaded = bench.data(plant, unloaded_motion)
    tables, recognitions, metrics = [], [], {}
    for name in tqdm(list(tools), desc="tools", leave=False):
        tool = library[name] if name in library.names else load_library([name]).tools[0]
        start = time.perf_counter()
        estimate = identify_tool(
            bench, unloaded, bench.data(plant.with_tool(tool), loaded_motion), method, weighted, consistent
        )
        seconds = time.perf_counter() - start
        recognition: Recognition = classifier.predict(estimate.phi_flange, estimate.covariance_flange)
        mass_error = 100.0 * (estimate.phi[0] / tool.mass - 1.0)
        tables.append(table3_rows(tool, estimate, bench.truth_in_joint_frame(tool)))
        recognitions.append(
            {
                "tool": name,
                "true_mass": tool.mass,
                "identified_mass": estimate.phi[0],
                "mass_error_pct": mass_error,
                "recognised": recognition.tool,
                "correct": recognition.tool == name,
                "confidence": recognition.confidence,
                **{f"{g}_m": recognition.geometry[g] for g in GEOMETRY_NAMES},
                "method": estimate.method,
                "cond": estimate.cond,
                "identification_s": seconds,
            }
        )
        metrics |= {
            f"mass_error_pct_{name}": float(mass_error),
            f"recognised_{name}": float(recognition.tool == name),
            f"confidence_{name}": float(recognition.confidence),
            f"relative_std_mass_{name}": float(estimate.relative_std[0]),
        }
    table = pd.concat(tables, ignore_index=True)
    summary = pd.DataFrame(recognitions)
    table.to_csv(output_dir / "table3_tools.csv", index=False)
    summary.to_csv(output_dir / "tool_recognition.csv", index=False)
    candidates.to_csv(output_dir / "tool_motion.csv", index=False)
    series = {f"{name} (lwrlab)": table.loc[table.tool == name, "relative_std"].to_numpy() for name in tools}
    series |= {
        f"{name} (paper)": table.loc[table.tool == name, "paper_relative_std"].to_numpy()
        for name in tools
        if table.loc[table.tool == name, "paper_relative_std"].notna().all()
    }
    relative_std_bars(
        LINK_PARAMETER_NAMES,
        series,
        output_dir / "table3_relative_std.png",
        "Tool parameters: %σ (Table III)",
    )
    metrics["max_abs_mass_error_pct"] = float(summary["mass_error_pct"].abs().max())
    metrics["recognition_accuracy"] = float(summary["correct"].mean())
    text = format_table3(table, summary)
    (output_dir / "summary.md").write_text(text + "\n")
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(text)
    return metrics


def format_table3(table: pd.DataFrame, summary: pd.DataFrame) -> str:
    """Table III (Φ and %σ per tool, beside the truth and the paper) and the recognition, as Markdown."""
    lines = ["## Table III: identified tool parameters (frame of joint 7)", ""]
    for name, rows in table.groupby("tool", sort=False):
        lines += [
            f"### {name}",
            "",
            rows.drop(columns=["tool"]).set_index("parameter").to_markdown(floatfmt=".4g"),
            "",
        ]
    lines += ["## Mass and recognition", "", summary.set_index("tool").to_markdown(floatfmt=".4g")]
    return "\n".join(lines)


# --- recognition benchmark ------------------------------------------------------------------------


def run_tool_recognition_benchmark(
    cfg: Any,
    output_dir: Path,
    classifiers: Mapping[str, ToolClassifier],
    n_seeds: int = 10,
    library: Sequence[str] | None = None,
    method: str = "joint",
    weighted: bool = True,
    consistent: bool = False,
    tool_motion: Callable[..., Any] | None = None,
    tool_motion_candidates: int = 8,
) -> dict[str, float]:
    """Task ``tool_recognition_benchmark``: every classifier × every library tool × ``n_seeds`` noise seeds.

    Each seed draws another robot truth and other sensor noise; each tool is identified by eq. (7)
    and recognised by every classifier of ``classifiers`` (unfitted plugins, by name; the other
    arguments as :func:`run_table3_tools`). Held-out geometry: each tool in turn
    is removed from the library and its geometry interpolated by the classifiers that can
    (``estimate_geometry``). Writes ``tool_recognition_trials.csv`` (classifier, seed, tool,
    recognised, correct, confidence), ``tool_recognition_accuracy.csv`` (classifier, accuracy,
    mean/min confidence of correct answers), ``geometry_interpolation.csv`` (classifier, seed, tool,
    true and estimated length/width in m, errors in mm), ``tool_identification.csv`` (seed, tool, mass
    error %), ``confusion_matrix.png`` and ``summary.md``.
    """
    output_dir.mkdir(parents=True, exist_ok=True)
    _, bench, plant_for, unloaded_motion, loaded_motion, _, tools = _setup(
        cfg, library, _required_motion(tool_motion), tool_motion_candidates
    )
    held_out = {
        (name, tool.name): copy.deepcopy(classifier).fit(tools.without(tool.name))
        for name, classifier in classifiers.items()
        for tool in tools
        if hasattr(classifier, "estimate_geometry")
    }
    classifiers = {name: copy.deepcopy(classifier).fit(tools) for name, classifier in classifiers.items()}
    library = tools
    trials, geometry, identification = [], [], []
    seeds = range(int(cfg.seed), int(cfg.seed) + int(n_seeds))
    progress = tqdm(total=len(seeds) * len(library), desc="identify and recognise", leave=False)
    for seed in seeds:
        plant = plant_for(seed)
        unloaded = bench.data(plant, unloaded_motion)
        for tool in library:
            estimate = identify_tool(
                bench,
                unloaded,
                bench.data(plant.with_tool(tool), loaded_motion),
                method,
                weighted,
                consistent,
            )
            phi, covariance = estimate.phi_flange, estimate.covariance_flange
            identification.append(
                {"seed": seed, "tool": tool.name, "mass_error_pct": 100.0 * (phi[0] / tool.mass - 1.0)}
            )
            for name, classifier in classifiers.items():
                recognition = classifier.predict(phi, covariance)
                trials.append(
                    {
                        "classifier": name,
                        "seed": seed,
                        "tool": tool.name,
                        "recognised": recognition.tool,
                        "correct": recognition.tool == tool.name,
                        "confidence": recognition.confidence,
                    }
                )
            for (name, held_name), classifier in held_out.items():
                if held_name == tool.name:
                    estimated = classifier.estimate_geometry(phi)
                    true = np.array([tool.geometry[g] for g in GEOMETRY_NAMES])
                    geometry.append(
                        {"classifier": name, "seed": seed, "tool": tool.name}
                        | {f"{g}_true_m": t for g, t in zip(GEOMETRY_NAMES, true, strict=True)}
                        | {f"{g}_estimated_m": e for g, e in zip(GEOMETRY_NAMES, estimated, strict=True)}
                        | {
                            f"{g}_error_mm": 1000 * (e - t)
                            for g, e, t in zip(GEOMETRY_NAMES, estimated, true, strict=True)
                        }
                    )
            progress.update()
    progress.close()
    trials_table, geometry_table, identification_table = (
        pd.DataFrame(trials),
        pd.DataFrame(geometry),
        pd.DataFrame(identification),
    )
    accuracy = trials_table.groupby("classifier", sort=False).agg(
        accuracy=("correct", "mean"), trials=("correct", "size")
    )
    correct = trials_table[trials_table.correct].groupby("classifier", sort=False)["confidence"]
    accuracy["mean_confidence"], accuracy["min_confidence_correct"] = correct.mean(), correct.min()
    matrices = {
        name: _confusion(trials_table[trials_table.classifier == name], library.names) for name in classifiers
    }
    confusion_matrices(
        library.names, matrices, accuracy["accuracy"].to_dict(), output_dir / "confusion_matrix.png"
    )
    trials_table.to_csv(output_dir / "tool_recognition_trials.csv", index=False)
    accuracy.to_csv(output_dir / "tool_recognition_accuracy.csv")
    geometry_table.to_csv(output_dir / "geometry_interpolation.csv", index=False)
    identification_table.to_csv(output_dir / "tool_identification.csv", index=False)
    metrics = {f"accuracy_{name}": float(value) for name, value in accuracy["accuracy"].items()}
    metrics["max_abs_mass_error_pct"] = float(identification_table["mass_error_pct"].abs().max())
    geometry_summary = pd.DataFrame()
    if not geometry_table.empty:
        errors = geometry_table.groupby("classifier", sort=False)[[f"{g}_error_mm" for g in GEOMETRY_NAMES]]
        geometry_summary = errors.agg(lambda e: float(np.sqrt(np.mean(e**2)))).add_suffix("_rms")
        for name, row in geometry_summary.iterrows():
            metrics |= {f"heldout_{column}_{name}": float(value) for column, value in row.items()}
    text = "\n".join(
        [
            f"## Tool recognition over {len(library)} tools × {len(seeds)} noise seeds",
            "",
            accuracy.to_markdown(floatfmt=".4g"),
            "",
            "## Tool mass error (%) over all trials",
            "",
            identification_table.groupby("tool")["mass_error_pct"]
            .describe()[["mean", "std", "min", "max"]]
            .to_markdown(floatfmt=".3g"),
            "",
            "## Held-out tools: geometry interpolated in feature space (RMS error, mm)",
            "",
            geometry_summary.to_markdown(floatfmt=".3g")
            if not geometry_summary.empty
            else "(no classifier interpolates geometry)",
        ]
    )
    (output_dir / "summary.md").write_text(text + "\n")
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(text)
    return metrics


def _confusion(trials: pd.DataFrame, names: tuple[str, ...]) -> np.ndarray:
    index = {name: i for i, name in enumerate(names)}
    matrix = np.zeros((len(names), len(names)), dtype=int)
    for true, recognised in zip(trials["tool"], trials["recognised"], strict=True):
        matrix[index[true], index[recognised]] += 1
    return matrix
