"""Compose the repository's config tree (``conf/``) in a test, as ``lwrlab`` would on the command line.

The tests import it as ``from composing import compose_config`` (pytest puts ``tests/`` on the path, as
for ``tracking_apps``). Apps of their own (tests/apps/) are run as processes by ``tracking_apps`` instead.
"""

from __future__ import annotations

from pathlib import Path

from hydra import compose, initialize_config_dir
from omegaconf import DictConfig

import lwrlab.conf  # noqa: F401  (registers the schemas conf/'s YAML files link, so they compose from CONF)

CONF = Path(__file__).resolve().parents[1] / "conf"
"""The repository's config tree; ``config.yaml`` is its primary config."""


def compose_config(*overrides: str, hydra_node: bool = False) -> DictConfig:
    """The primary config ``conf/config.yaml`` composed with command-line ``overrides``.

    Parameters
    ----------
    *overrides
        Hydra overrides as typed after ``lwrlab`` (``"plant=log"``, ``"data.paths=[a.csv]"``,
        ``"hydra.searchpath=[file://…]"``), applied in order.
    hydra_node
        Keep the ``hydra`` node (launcher, sweeper, job settings), which Hydra drops by default.

    Returns
    -------
    DictConfig
        The composed config; composition errors (a wrong type, an unknown key or option) raise
        Hydra's ``ConfigCompositionException`` here.

    Examples
    --------
    >>> compose_config("task=identification", "seed=3").seed
    3
    """
    # Hydra's global state is set up and torn down around each composition, so tests stay independent.
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        return compose("config", overrides=list(overrides), return_hydra_config=hydra_node)
