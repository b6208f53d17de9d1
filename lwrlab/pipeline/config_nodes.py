"""Config nodes as the plain values the stages take (a mapping of settings, checked to be one)."""

from __future__ import annotations

from typing import Any

from lwrlab.errors import ConfigError


def plain(value: Any) -> Any:
    """``value`` with any config node in it resolved into plain dicts and lists."""
    from omegaconf import OmegaConf

    return OmegaConf.to_container(value, resolve=True) if OmegaConf.is_config(value) else value


def resolved_mapping(node: Any, key: str) -> dict[str, Any]:
    """The config node ``node`` (found at ``key``) resolved into a plain ``dict``.

    Raises
    ------
    ConfigError
        When the node is not a mapping (a list, a value, null), naming ``key``.
    """
    container = plain(node)
    if not isinstance(container, dict):
        raise ConfigError(f"{key} must be a mapping of settings, got {container!r}")
    return {str(name): value for name, value in container.items()}


def processing_settings(cfg: Any) -> dict[str, Any]:
    """``measurement.processing``: the keyword arguments of :func:`lwrlab.signal.processing.process`."""
    return resolved_mapping(cfg.measurement.processing, "measurement.processing")


def statistics_settings(cfg: Any) -> dict[str, Any] | None:
    """The ``statistics`` group's settings (bootstrap resamples, block, confidence, seed); None without it."""
    return resolved_mapping(cfg.statistics, "statistics") if "statistics" in cfg else None


def tracking_uri(cfg: Any) -> str | None:
    """``tracking.uri``: the job's MLflow store, where a model URI setting is looked up (None without
    tracking: ``MLFLOW_TRACKING_URI`` or MLflow's default)."""
    from omegaconf import OmegaConf

    value = OmegaConf.select(cfg, "tracking.uri", default=None) if OmegaConf.is_config(cfg) else None
    return None if value in (None, "") else str(value)
