"""Command-line entry point: ``lwrlab [group=option ...] [key=value ...]`` (a Hydra app)."""

from __future__ import annotations

import logging
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.utils import instantiate
from omegaconf import DictConfig

log = logging.getLogger("lwrlab")

CONFIG_DIR = str(Path(__file__).resolve().parents[1] / "conf")
"""The config tree beside the package (an absolute path: a relative one would be read as a module)."""


def run(cfg: DictConfig, output_dir: Path) -> dict[str, float]:
    """Run the pipeline stage selected by ``cfg.task`` (a function ``(cfg, output_dir) -> metrics``)."""
    stage = instantiate(cfg.task)
    metrics = stage(cfg, output_dir)
    log.info("artifacts written to %s", output_dir)
    return metrics


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="config")
def main(cfg: DictConfig) -> dict[str, float]:
    """Hydra entry point; the tracking callback logs the returned metrics and the output folder."""
    return run(cfg, Path(HydraConfig.get().runtime.output_dir))


if __name__ == "__main__":
    main()
