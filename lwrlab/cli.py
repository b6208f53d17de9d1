"""Command-line entry point: ``lwrlab [group=option ...] [key=value ...]`` (a Hydra app)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf

from lwrlab.pipeline.identification import format_report, identify, write_report

log = logging.getLogger("lwrlab")

CONFIG_DIR = str(Path(__file__).resolve().parents[1] / "conf")
"""The config tree beside the package (an absolute path: a relative one would be read as a module)."""


def run(cfg: DictConfig, output_dir: Path) -> dict[str, float]:
    """Run the identification chain configured by ``cfg``; write its artifacts; return its metrics."""
    robot = instantiate(cfg.robot)
    report = identify(
        robot=robot,
        motion_source=instantiate(cfg.trajectory),
        validation_source=instantiate(cfg.validation),
        plant=instantiate(cfg.plant)(robot=robot),
        estimator=instantiate(cfg.estimator),
        rate_hz=cfg.measurement.rate_hz,
        processing=OmegaConf.to_container(cfg.measurement.processing, resolve=True),
    )
    robot_config: Any = OmegaConf.to_container(cfg.robot, resolve=True)
    write_report(report, output_dir, robot_config)
    print(format_report(report))
    log.info("artifacts written to %s", output_dir)
    return report.metrics


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="config")
def main(cfg: DictConfig) -> dict[str, float]:
    """Hydra entry point; the tracking callback logs the returned metrics and the output folder."""
    return run(cfg, Path(HydraConfig.get().runtime.output_dir))


if __name__ == "__main__":
    main()
