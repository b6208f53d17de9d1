"""The code MLflow runs to load an identified payload (MLflow's *models from code*).

:func:`~lwrlab.tracking.models.model_logging.log_payload_model` gives MLflow this file instead of a
pickled object, as for an identified robot (:mod:`.identified_model_code`). Nothing is unpickled.
"""

from mlflow.models import set_model

from lwrlab.tracking.models.payload_pyfunc import PayloadTorqueModel

set_model(PayloadTorqueModel())
