"""The paper's whole chain (its Fig. 1) as one job: the default of ``lwrlab``.

Exciting motion (the configured ``trajectory``: by default the shipped optimum of §III) → measurement
on the plant → base-parameter identification and cross-validation (§II.D, III.E) → tool
identification and recognition (§II.E) → painting-path optimisation (§IV) → painting in contact
with forces estimated from joint torques (§V, VI.B). Each stage writes where it always does: the
identification report at the top of ``output_dir``, the painting stage under ``painting/``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from lwrlab.pipeline.config_nodes import processing_settings
from lwrlab.pipeline.identification import identify_configured
from lwrlab.pipeline.identification.report import format_report, write_report
from lwrlab.pipeline.identification.task import robot_description

log = logging.getLogger(__name__)

PaintingStage = Callable[..., dict[str, float]]
"""``run_painting`` with its settings bound: ``(cfg, output_dir, identification=…) -> metrics``."""


def run_paper_chain(cfg: Any, output_dir: Path, painting: PaintingStage) -> dict[str, float]:
    """Task ``paper_chain``: identification, then tool recognition and painting with the identified model.

    Returns the identification metrics (``rms_joint1`` …, ``base_parameter_error``, …), the painting
    metrics (``rms_<roller>_<model>_<feedback>_<comparison>``, ``coverage_…``, ``duration_s_…``) and
    the wall time of each stage (``stage_identification_s``, ``stage_painting_s``).
    """
    started = time.perf_counter()
    report = identify_configured(cfg)
    write_report(report, output_dir, robot_description(cfg), processing=processing_settings(cfg))
    print("# 1. Identification\n\n" + format_report(report) + "\n")
    identified_s = time.perf_counter() - started

    print("# 2. Tool recognition, painting path and force control\n")
    metrics = dict(report.metrics)
    metrics.update(painting(cfg, output_dir / "painting", identification=report))
    metrics["stage_identification_s"] = identified_s
    metrics["stage_painting_s"] = time.perf_counter() - started - identified_s
    log.info(
        "stages: identification %.1f s, tool + painting %.1f s", identified_s, metrics["stage_painting_s"]
    )
    return metrics
