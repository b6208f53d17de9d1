"""The code MLflow runs to load an identified model (MLflow's *models from code*).

:func:`~lwrlab.tracking.models.model_logging.log_identified_model` gives MLflow this file instead of a
pickled object: the model folder keeps a copy of it, and ``mlflow.pyfunc.load_model`` runs the copy,
which names the class of the installed lwrlab. Nothing is unpickled.
"""

from mlflow.models import set_model

from lwrlab.tracking.models.identified_pyfunc import IdentifiedTorqueModel

set_model(IdentifiedTorqueModel())
