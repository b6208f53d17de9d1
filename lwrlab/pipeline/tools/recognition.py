"""Tool tasks: identify each tool by eq. (7) and recognise it (Table III); benchmark the recognition.

Both tasks run the same chain for every tool: the simulated robot executes an exciting motion
unloaded and a tool motion carrying the tool, the measurements are processed as in §III.E, the
tool's 10 parameters are identified (:mod:`lwrlab.pipeline.tools.bench`, the computation) and a
classifier picks the library tool they belong to (:mod:`lwrlab.tools.recognition`). ``run_*``
build the objects from the config, run the chain and write the tables and figures (the tracking
callback logs the folder to MLflow).
"""

from __future__ import annotations

import copy
import json
import logging
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from lwrlab.errors import ConfigError
from lwrlab.figures.tools import confusion_matrices, relative_std_bars
from lwrlab.identification.payload import PayloadEstimate
from lwrlab.model.inertia import LINK_PARAMETER_NAMES
from lwrlab.pipeline.config_nodes import processing_settings
from lwrlab.pipeline.tools.bench import (
    ToolBench,
    ToolData,
    ToolPlant,
    checked_motion,
    identify_tool,
    tool_motion,
)
from lwrlab.pipeline.tools.library import load_library
from lwrlab.reference import paper_results
from lwrlab.tools.library import PAPER_TOOLS, ToolLibrary
from lwrlab.tools.model import GEOMETRY_NAMES, Tool
from lwrlab.tools.recognition import UNKNOWN_TOOL, Recognition, ToolClassifier, UnknownToolWarning
from lwrlab.trajectory.core import Trajectory

log = logging.getLogger(__name__)


def _required_motion(source: Callable[..., Any] | None) -> Callable[..., Any]:
    if source is None:
        raise ValueError(
            "the tool stages need `task.tool_motion`: a partial motion plugin (`_partial_: true`) with a seed"
        )
    return source


@dataclass(frozen=True)
class ToolStage:
    """What both tool tasks need, built from the config."""

    bench: ToolBench
    plant_for: Callable[[int], ToolPlant]
    """The unloaded simulated plant drawn with a seed."""
    unloaded_motion: Trajectory
    loaded_motion: Trajectory
    candidates: pd.DataFrame
    """The tool-motion candidates' seeds and tool criterion (:func:`tool_motion`)."""
    library: ToolLibrary

    def identify(
        self, plant: ToolPlant, unloaded: ToolData, tool: Tool, method: str, weighted: bool, consistent: bool
    ) -> PayloadEstimate:
        """``tool``'s parameters: ``plant`` carries it on the loaded motion; ``unloaded``: rows without."""
        loaded = self.bench.data(plant.with_tool(tool), self.loaded_motion)
        return identify_tool(self.bench, unloaded, loaded, method, weighted, consistent)


def _setup(
    cfg: Any, library_names: Sequence[str] | None, motion_source: Callable[..., Any], candidates: int
) -> ToolStage:
    """Bench, unloaded plant factory, unloaded and tool motions, library: what both tasks need."""
    from hydra.utils import instantiate

    if getattr(getattr(instantiate(cfg.plant), "func", None), "recorded", False):  # a plant that replays logs
        raise ConfigError(
            "the simulated tool stages (Table III, recognition benchmark) attach tools to a simulated "
            "robot; for a payload in recorded logs use task=payload plant=log "
            "'task.unloaded_paths=[…]' 'task.loaded_paths=[…]'"
        )
    robot = instantiate(cfg.robot)
    rate = float(cfg.measurement.rate_hz)
    unloaded_motion = checked_motion(instantiate(cfg.trajectory), robot, rate, "exciting motion (unloaded)")
    loaded_motion, candidate_table = tool_motion(motion_source, candidates, robot, rate)

    def plant_for(seed: int) -> ToolPlant:
        plant: ToolPlant = instantiate(cfg.plant, seed=seed, tool=None, show_progress=False)(robot=robot)
        return plant

    return ToolStage(
        ToolBench.for_robot(robot, processing_settings(cfg)),
        plant_for,
        unloaded_motion,
        loaded_motion,
        candidate_table,
        load_library(list(library_names) if library_names else None),
    )


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
    stage = _setup(cfg, library, _required_motion(tool_motion), tool_motion_candidates)
    bench = stage.bench
    classifier: ToolClassifier = instantiate(cfg.classifier).fit(stage.library)
    plant = stage.plant_for(int(cfg.seed))
    unloaded = bench.data(plant, stage.unloaded_motion)
    tables: list[pd.DataFrame] = []
    recognitions: list[dict[str, Any]] = []
    metrics: dict[str, float] = {}
    for name in tqdm(list(tools), desc="tools", leave=False):
        tool = stage.library[name] if name in stage.library.names else load_library([name]).tools[0]
        start = time.perf_counter()
        estimate = stage.identify(plant, unloaded, tool, method, weighted, consistent)
        seconds = time.perf_counter() - start
        recognition: Recognition = classifier.predict(estimate.phi_flange, estimate.covariance_flange)
        if not recognition.known:
            warnings.warn(f"{name}: {recognition.describe()}", UnknownToolWarning, stacklevel=1)
        mass_error = 100.0 * (estimate.phi[0] / tool.mass - 1.0)
        tables.append(table3_rows(tool, estimate, bench.truth_in_joint_frame(tool)))
        recognitions.append(
            {
                "tool": name,
                "true_mass": tool.mass,
                "identified_mass": estimate.phi[0],
                "mass_error_pct": mass_error,
                "recognised": recognition.tool,
                "nearest": recognition.nearest,
                "correct": recognition.tool == name,
                "confidence": recognition.confidence,
                "noise_distance_sigma": recognition.noise_distance,
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
            f"noise_distance_{name}": float(recognition.noise_distance),
            f"relative_std_mass_{name}": float(estimate.relative_std[0]),
        }
    table = pd.concat(tables, ignore_index=True)
    summary = pd.DataFrame(recognitions)
    table.to_csv(output_dir / "table3_tools.csv", index=False)
    summary.to_csv(output_dir / "tool_recognition.csv", index=False)
    stage.candidates.to_csv(output_dir / "tool_motion.csv", index=False)
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
    arguments as :func:`run_table3_tools`). Held-out tools: each tool in turn is removed from the
    library; every classifier must then call it unknown (open set: the tools a library lacks), and
    the classifiers that can (``estimate_geometry``) interpolate its geometry. Writes
    ``tool_recognition_trials.csv`` (classifier, seed, tool, recognised, nearest, correct, confidence,
    distance, noise distance in σ), ``tool_recognition_heldout.csv`` (classifier, seed, held-out tool,
    nearest, distances, rejected), ``tool_recognition_accuracy.csv`` (classifier, accuracy, share
    called unknown, largest noise distance of a library tool, held-out rejection rate and smallest
    held-out noise distance, mean/min confidence of correct answers),
    ``geometry_interpolation.csv`` (classifier, seed, tool,
    true and estimated length/width in m, errors in mm), ``tool_identification.csv`` (seed, tool, mass
    error %), ``confusion_matrix.png`` and ``summary.md``.
    """
    output_dir.mkdir(parents=True, exist_ok=True)
    stage = _setup(cfg, library, _required_motion(tool_motion), tool_motion_candidates)
    bench, tools = stage.bench, stage.library
    held_out = {
        (name, tool.name): copy.deepcopy(classifier).fit(tools.without(tool.name))
        for name, classifier in classifiers.items()
        for tool in tools
    }
    classifiers = {name: copy.deepcopy(classifier).fit(tools) for name, classifier in classifiers.items()}
    trials: list[dict[str, Any]] = []
    held_out_trials: list[dict[str, Any]] = []
    geometry: list[dict[str, Any]] = []
    identification: list[dict[str, Any]] = []
    seeds = range(int(cfg.seed), int(cfg.seed) + int(n_seeds))
    progress = tqdm(total=len(seeds) * len(tools), desc="identify and recognise", leave=False)
    for seed in seeds:
        plant = stage.plant_for(seed)
        unloaded = bench.data(plant, stage.unloaded_motion)
        for tool in tools:
            estimate = stage.identify(plant, unloaded, tool, method, weighted, consistent)
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
                        "nearest": recognition.nearest,
                        "correct": recognition.tool == tool.name,
                        "confidence": recognition.confidence,
                        "distance": recognition.distance,
                        "noise_distance": recognition.noise_distance,
                    }
                )
            for (name, held_name), classifier in held_out.items():
                if held_name != tool.name:
                    continue
                unseen = classifier.predict(phi, covariance)
                held_out_trials.append(
                    {
                        "classifier": name,
                        "seed": seed,
                        "tool": tool.name,
                        "nearest": unseen.nearest,
                        "distance": unseen.distance,
                        "noise_distance": unseen.noise_distance,
                        "rejected": not unseen.known,
                    }
                )
                if hasattr(classifier, "estimate_geometry"):
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
    trials_table, held_out_table, geometry_table, identification_table = (
        pd.DataFrame(trials),
        pd.DataFrame(held_out_trials),
        pd.DataFrame(geometry),
        pd.DataFrame(identification),
    )
    trials_table["unknown"] = trials_table["recognised"] == UNKNOWN_TOOL
    accuracy = trials_table.groupby("classifier", sort=False).agg(
        accuracy=("correct", "mean"),
        trials=("correct", "size"),
        called_unknown=("unknown", "mean"),
        max_noise_distance=("noise_distance", "max"),
    )
    by_classifier = held_out_table.groupby("classifier", sort=False)
    accuracy["heldout_rejected"] = by_classifier["rejected"].mean()
    accuracy["min_heldout_noise_distance"] = by_classifier["noise_distance"].min()
    correct = trials_table[trials_table.correct].groupby("classifier", sort=False)["confidence"]
    accuracy["mean_confidence"], accuracy["min_confidence_correct"] = correct.mean(), correct.min()
    matrices = {
        name: _confusion(trials_table[trials_table.classifier == name], tools.names) for name in classifiers
    }
    accuracy_by_classifier = {str(name): float(value) for name, value in accuracy["accuracy"].items()}
    confusion_matrices(tools.names, matrices, accuracy_by_classifier, output_dir / "confusion_matrix.png")
    trials_table.to_csv(output_dir / "tool_recognition_trials.csv", index=False)
    held_out_table.to_csv(output_dir / "tool_recognition_heldout.csv", index=False)
    accuracy.to_csv(output_dir / "tool_recognition_accuracy.csv")
    geometry_table.to_csv(output_dir / "geometry_interpolation.csv", index=False)
    identification_table.to_csv(output_dir / "tool_identification.csv", index=False)
    metrics = {f"accuracy_{name}": value for name, value in accuracy_by_classifier.items()}
    metrics |= {f"heldout_rejected_{name}": float(v) for name, v in accuracy["heldout_rejected"].items()}
    metrics["max_abs_mass_error_pct"] = float(identification_table["mass_error_pct"].abs().max())
    geometry_summary = pd.DataFrame()
    if not geometry_table.empty:
        errors = geometry_table.groupby("classifier", sort=False)[[f"{g}_error_mm" for g in GEOMETRY_NAMES]]
        geometry_summary = errors.agg(_rms).add_suffix("_rms")
        for classifier_name, row in geometry_summary.iterrows():
            metrics |= {f"heldout_{column}_{classifier_name}": float(value) for column, value in row.items()}
    text = "\n".join(
        [
            f"## Tool recognition over {len(tools)} tools × {len(seeds)} noise seeds (held out: each "
            "tool removed from the library in turn, to be called unknown)",
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


def _rms(errors: pd.Series) -> float:
    return float(np.sqrt(np.mean(errors**2)))


def _confusion(trials: pd.DataFrame, names: tuple[str, ...]) -> np.ndarray:
    index = {name: i for i, name in enumerate(names)}
    matrix = np.zeros((len(names), len(names)), dtype=int)
    for true, recognised in zip(trials["tool"], trials["recognised"], strict=True):
        if recognised in index:  # an unknown answer has no column: the row sums to fewer trials
            matrix[index[true], index[recognised]] += 1
    return matrix
