"""Typed schemas of the settings in ``conf/``: a wrong type or an unknown key fails when Hydra composes.

One convention for every group typed here: **the YAML holds the values, the schema holds the types.**
A schema field has no default (OmegaConf reads it as ``???``, MISSING), so every value is written
once, in the YAML file a user reads and a preset overrides, with its unit in a comment; the schema
says what type each key has and which keys exist. ``tests/test_config_tree.py`` composes every option
and checks that none leaves a key MISSING. Ranges a type cannot say (a noise level ≥ 0, a duration
> 0) are rules of :mod:`lwrlab.pipeline.config_checks`, checked when the job starts.

A YAML file links its schema first in its defaults list, its own values after it::

    defaults:
      - /schema/measurement/default@_here_
      - _self_

named as a config (``/schema/<group>/<name>``), not as a group choice (``/schema/<group>: <name>``):
a choice would appear in Hydra's runtime choices, which the tracking logs as the job's options.
:data:`SCHEMAS` lists them as Hydra ConfigStore entries (group ``schema/<group>``). Importing the
config package :mod:`lwrlab.conf` registers them, and Hydra imports it when it reads
``pkg://lwrlab.conf`` (what ``lwrlab`` does), so nothing else has to; code composing the tree from
its folder (``initialize_config_dir``) imports :mod:`lwrlab.conf` first. These modules import only
:mod:`dataclasses` and :mod:`typing`: ``lwrlab`` starts as fast as before.

To add a setting to a typed option: write its value (and unit) in the option's YAML and its field
(type and one-line docstring) in the schema; a range goes into the rule table of
:mod:`lwrlab.pipeline.config_checks`.
"""

from __future__ import annotations

from lwrlab.config.measurement import MeasurementSettings
from lwrlab.config.plant import DataSettings, LogPlantSettings, SimulatedPlantSettings
from lwrlab.config.root import RootSettings
from lwrlab.config.statistics import StatisticsSettings
from lwrlab.config.task import TASK_SCHEMAS
from lwrlab.config.tracking import TrackingStoreSettings

SCHEMA_GROUP = "schema"
"""ConfigStore group under which the schemas live: ``/schema/<group>`` in a defaults list."""

SCHEMAS: tuple[tuple[str, str, type], ...] = (
    ("root", "config", RootSettings),
    ("measurement", "default", MeasurementSettings),
    ("plant", "simulated", SimulatedPlantSettings),
    ("plant", "log", LogPlantSettings),
    ("data", "log", DataSettings),
    ("statistics", "block_bootstrap", StatisticsSettings),
    ("tracking", "mlflow", TrackingStoreSettings),
    *(("task", name, schema) for name, schema in TASK_SCHEMAS.items()),
)
"""(group, name, dataclass) of every schema: ``/schema/<group>/<name>@…`` in a YAML's defaults list."""

__all__ = ["SCHEMAS", "SCHEMA_GROUP"]
