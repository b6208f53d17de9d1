"""The config tree as a package, ``lwrlab.conf`` (``lwrlab/conf`` links here; a wheel copies it in).

Hydra reads it as ``pkg://lwrlab.conf`` (see :mod:`lwrlab.resources`), which imports this file:
importing it registers the typed schemas its YAML files link (``/schema/<group>/<name>``, from
:mod:`lwrlab.config`) in Hydra's ConfigStore. Code that composes the tree from its folder
(``initialize_config_dir``) imports ``lwrlab.conf`` first.
"""

from hydra.core.config_store import ConfigStore

from lwrlab.config import SCHEMA_GROUP, SCHEMAS

for _group, _name, _schema in SCHEMAS:
    ConfigStore.instance().store(group=f"{SCHEMA_GROUP}/{_group}", name=_name, node=_schema)
