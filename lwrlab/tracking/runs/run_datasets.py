"""A run's data as MLflow dataset inputs: what the runs table's Dataset column shows.

Each :class:`~lwrlab.tracking.job_config.datasets.DatasetUse` becomes one input, named and digested,
its source the file, and its role as MLflow's ``mlflow.data.context`` tag (``identification``,
``validation``), which the Dataset column shows beside the name. The file is not read by MLflow (no
schema, no profile): logging it costs a hash of its content.
"""

from __future__ import annotations

import json
from collections.abc import Sequence

from mlflow.entities import Dataset, DatasetInput, InputTag
from mlflow.tracking import MlflowClient
from mlflow.utils.mlflow_tags import MLFLOW_DATASET_CONTEXT

from lwrlab.tracking.job_config.datasets import DatasetUse, content_digest
from lwrlab.tracking.store.sqlite import retry_locked

SOURCE_TYPE = "local"
"""MLflow's source type of a file on the machine that ran the job."""


def dataset_input(use: DatasetUse) -> DatasetInput:
    """The MLflow dataset input of one dataset a job used."""
    dataset = Dataset(
        name=use.name,
        digest=content_digest(use.path),
        source_type=SOURCE_TYPE,
        source=json.dumps({"uri": use.path.resolve().as_uri()}),
    )
    return DatasetInput(dataset, tags=[InputTag(MLFLOW_DATASET_CONTEXT, use.role)])


def log_datasets(client: MlflowClient, run_id: str, uses: Sequence[DatasetUse]) -> list[DatasetInput]:
    """Record ``uses`` as the run's dataset inputs (one store call); returns them."""
    inputs = [dataset_input(use) for use in uses]
    if inputs:
        retry_locked(client.log_inputs, run_id, datasets=inputs)
    return inputs


__all__ = ["SOURCE_TYPE", "dataset_input", "log_datasets"]
