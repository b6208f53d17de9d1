"""A new SQLite MLflow store starts as a copy of an empty, fully migrated database.

MLflow builds the schema of a new SQLite store by replaying all its Alembic migrations (some sixty
scripts, each altering tables in a transaction of its own): 2 to 3.6 s on a busy 2-core machine, paid by
every new store (each test's, each benchmark round's, each new project folder's). The result depends
only on the installed MLflow, so it is built once per MLflow version, with MLflow's own
``_initialize_tables``, kept in the user's cache folder, and copied into place for later stores. MLflow
still opens the copy as it opens any store: it checks the schema revision and creates the Default
experiment with that store's artifact root.

Anything unexpected (a read-only cache folder, a changed private MLflow function) leaves the store
to MLflow's own migration.
"""

from __future__ import annotations

import logging
import os
import shutil
from importlib import metadata
from pathlib import Path

try:  # POSIX only; elsewhere no template is built (MLflow migrates each store)
    import fcntl
except ImportError:  # pragma: no cover
    fcntl = None  # type: ignore[assignment]

log = logging.getLogger(__name__)

CACHE_ENVIRONMENT_VARIABLE = "LWRLAB_CACHE_DIR"
"""Where the template is kept, if set; otherwise ``$XDG_CACHE_HOME/lwrlab`` or ``~/.cache/lwrlab``."""


def cache_folder() -> Path:
    """The folder of lwrlab's caches (see :data:`CACHE_ENVIRONMENT_VARIABLE`)."""
    configured = os.environ.get(CACHE_ENVIRONMENT_VARIABLE)
    if configured:
        return Path(configured)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "lwrlab"


def template_path() -> Path:
    """The empty migrated database of the installed MLflow version."""
    return cache_folder() / f"mlflow-{metadata.version('mlflow')}-sqlite-schema.db"


def _build_template(template: Path) -> None:
    """Migrate an empty database with MLflow's own code, then move it into place (atomically)."""
    import sqlalchemy
    from mlflow.store.db.utils import _initialize_tables

    building = template.with_name(f"{template.name}.{os.getpid()}.building")
    building.unlink(missing_ok=True)
    engine = sqlalchemy.create_engine(f"sqlite:///{building}")
    try:
        _initialize_tables(engine)
    except BaseException:
        building.unlink(missing_ok=True)
        raise
    finally:
        engine.dispose()
    os.replace(building, template)


def copy_schema_template(database: Path) -> bool:
    """Give the new, empty store ``database`` a migrated schema by copying the template (built if missing).

    Returns whether it did; ``False`` leaves the store to MLflow's migration. The caller holds the
    store's lock; the template has a lock of its own, so that parallel first uses build it once.
    """
    if fcntl is None or database.exists() or database.with_name(database.name + "-wal").exists():
        return False
    try:
        template = template_path()
        template.parent.mkdir(parents=True, exist_ok=True)
        with open(template.with_name(template.name + ".lock"), "a+") as lock:
            fcntl.flock(lock.fileno(), fcntl.LOCK_EX)
            if not template.is_file():
                _build_template(template)
        database.parent.mkdir(parents=True, exist_ok=True)
        copying = database.with_name(f"{database.name}.{os.getpid()}.copying")
        shutil.copyfile(template, copying)
        try:
            _verify_schema(copying)  # a template that the installed MLflow would refuse is rebuilt next time
        except Exception:
            copying.unlink(missing_ok=True)
            template.unlink(missing_ok=True)
            raise
        os.replace(copying, database)  # never a half-copied store under the store's name
        return True
    except Exception as error:  # the store is then migrated by MLflow, as without a template
        log.debug("no schema template for %s: %s", database, error)
        return False


def _verify_schema(database: Path) -> None:
    """Raise unless ``database`` has the schema revision of the installed MLflow (MLflow's own check)."""
    import sqlalchemy
    from mlflow.store.db.utils import _verify_schema as verify

    engine = sqlalchemy.create_engine(f"sqlite:///{database}")
    try:
        verify(engine)
    finally:
        engine.dispose()


__all__ = ["CACHE_ENVIRONMENT_VARIABLE", "cache_folder", "copy_schema_template", "template_path"]
