"""scikit-learn's parameter protocol (``get_params`` / ``set_params``) without scikit-learn.

An estimator's hyper-parameters are the keyword arguments of its ``__init__``, stored untouched
under the same names; :class:`HyperParameters` reads them back from the signature, so
``sklearn.base.clone`` (where scikit-learn is installed) and :func:`clone_estimator` (always)
build an unfitted copy with the same settings. A plugin's settings take no Python default: its
YAML (``conf/estimator/<name>.yaml``) is the one place of their values.

Examples
--------
>>> class Ridge(HyperParameters):
...     def __init__(self, *, alpha: float, fit_friction: bool) -> None:
...         self.alpha = alpha
...         self.fit_friction = fit_friction
>>> Ridge(alpha=0.1, fit_friction=True).get_params()
{'alpha': 0.1, 'fit_friction': True}
>>> Ridge(alpha=0.1, fit_friction=True).set_params(alpha=2.0)
Ridge(alpha=2.0, fit_friction=True)
>>> clone_estimator(Ridge(alpha=0.5, fit_friction=False))
Ridge(alpha=0.5, fit_friction=False)
"""

from __future__ import annotations

import copy
import inspect
from typing import Any, Self


class HyperParameters:
    """``get_params`` / ``set_params`` / ``repr`` from the ``__init__`` signature (scikit-learn's rules:
    no ``*args``, every keyword stored as an attribute of the same name)."""

    @classmethod
    def _param_names(cls) -> list[str]:
        """The keyword arguments of ``__init__``, sorted (scikit-learn's order)."""
        if cls.__init__ is object.__init__:
            return []
        parameters = inspect.signature(cls.__init__).parameters.values()
        if any(p.kind == p.VAR_POSITIONAL for p in parameters):
            raise TypeError(f"{cls.__name__}.__init__ takes *args: hyper-parameters must be named keywords")
        return sorted(p.name for p in parameters if p.name != "self" and p.kind != p.VAR_KEYWORD)

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The hyper-parameters by name; with ``deep``, those of nested estimators as ``name__key``."""
        params = {}
        for name in self._param_names():
            value = getattr(self, name)
            if deep and hasattr(value, "get_params") and not isinstance(value, type):
                params.update({f"{name}__{key}": inner for key, inner in value.get_params(deep=True).items()})
            params[name] = value
        return params

    def set_params(self, **params: Any) -> Self:
        """Set hyper-parameters by name (``name__key`` reaches into a nested estimator); returns self."""
        valid = self._param_names()
        nested: dict[str, dict[str, Any]] = {}
        for key, value in params.items():
            name, _, inner = key.partition("__")
            if name not in valid:
                raise ValueError(f"invalid parameter {name!r} for {type(self).__name__}; valid: {valid}")
            if inner:
                nested.setdefault(name, {})[inner] = value
            else:
                setattr(self, name, value)
        for name, inner_params in nested.items():
            getattr(self, name).set_params(**inner_params)
        return self

    def __repr__(self) -> str:
        """The class and its hyper-parameters, less those left at a Python default (a method's constant:
        settings have none)."""
        defaults = {p.name: p.default for p in inspect.signature(type(self).__init__).parameters.values()}
        changed = []
        for name, value in self.get_params(deep=False).items():
            default = defaults.get(name, inspect.Parameter.empty)
            try:
                same = bool(value is default or value == default)
            except (TypeError, ValueError):  # arrays and the like compare element-wise
                same = False
            if not same:
                changed.append(f"{name}={value!r}")
        return f"{type(self).__name__}({', '.join(changed)})"


def clone_estimator(estimator: Any) -> Any:
    """A fresh, unfitted estimator with (copies of) the same hyper-parameters, as ``sklearn.base.clone``."""
    if not hasattr(estimator, "get_params"):
        raise TypeError(
            f"{type(estimator).__name__} has no get_params: "
            "estimators follow scikit-learn's parameter protocol "
            "(derive from lwrlab.identification.hyperparameters.HyperParameters)"
        )
    params = {
        name: clone_estimator(value)
        if hasattr(value, "get_params") and not isinstance(value, type)
        else copy.deepcopy(value)
        for name, value in estimator.get_params(deep=False).items()
    }
    return type(estimator)(**params)
