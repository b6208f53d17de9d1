"""Friction laws: how each drive's friction depends on its joint-side speed ``v`` (rad/s).

A friction law (config group ``friction``, plugins in ``plugins/friction/``) is linear in its
coefficients, so identification fits them as regressor columns; what is not linear (the width of a
smooth Coulomb step, the Stribeck speed) is a *shape* setting, fixed, or chosen on a grid by block
cross-validation (:mod:`lwrlab.identification.friction_choice`). Every law has the paper's terms,
which the robot's ``friction_terms`` switch on or off:

- ``coulomb`` (``FC``, N·m): ``FC·s(v)`` with the law's Coulomb shape ``s`` (|s| ≤ 1): ``sign(v)``
  for the paper's law, ``tanh(v/ε)`` for a smooth one;
- ``viscous`` (``FV``, N·m·s/rad): ``FV·v``;
- ``offset`` (``FO``, N·m): a constant torque-sensor or current offset;

and may add terms of its own (:attr:`FrictionLaw.extra_terms`, e.g. a Stribeck bump). The drive
train adds ``rotor`` (``IA``, kg·m²): the rotor inertia reflected to the joint side, acting on the
drive's joint-side acceleration. Each term is one column per drive, loading the joints through the
coupling (:mod:`lwrlab.model.drive_train`).

The protocol is small (:class:`FrictionLaw`); the paper's law, :class:`SignCoulomb`, lives here as
every robot's default, the others are plugins.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from lwrlab.errors import ConfigError


@dataclass(frozen=True)
class DriveTerm:
    """A column family: one regressor column per drive."""

    name: str
    """Term name, as in ``robot.friction_terms`` (``coulomb``, ``stribeck``, …)."""
    prefix: str
    """Prefix of its parameter names (``FC`` → ``FC1`` … ``FCN``)."""
    unit: str
    """Unit of its coefficients."""
    nonnegative: bool
    """Whether a physically consistent estimate keeps its coefficients ≥ 0."""
    drifts: bool = True
    """Whether its torque is friction, which changes from one motion or day to the next
    (temperature, speed range): the prediction intervals
    (:mod:`lwrlab.identification.prediction_error`) and the collision thresholds
    (:mod:`lwrlab.monitoring.spread`) allow for that change. Offsets and rotor inertias do not drift."""


STANDARD_TERMS: dict[str, DriveTerm] = {
    "coulomb": DriveTerm("coulomb", "FC", "N·m", True),
    "viscous": DriveTerm("viscous", "FV", "N·m·s/rad", True),
    "offset": DriveTerm("offset", "FO", "N·m", False, drifts=False),
    "rotor": DriveTerm("rotor", "IA", "kg·m²", True, drifts=False),
}
"""The terms every law shares (``rotor``: the drive train's reflected rotor inertia)."""


@runtime_checkable
class FrictionLaw(Protocol):
    """A friction law: the Coulomb shape, the law's own terms, its shape settings and their grid."""

    name: str
    """Short name reported in runs (``sign``, ``smooth``, …)."""

    @property
    def extra_terms(self) -> tuple[DriveTerm, ...]:
        """Terms beyond the standard ones (a Stribeck bump, a direction asymmetry); may be empty."""
        ...

    def coulomb_shape(self, v: np.ndarray) -> np.ndarray:
        """``s(v)``, |s| ≤ 1, of joint-side drive speeds ``v`` (N, N_D) rad/s: the ``coulomb`` column."""
        ...

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """The column of one of :attr:`extra_terms` at speeds ``v`` (N, N_D)."""
        ...

    def settings(self) -> dict[str, Any]:
        """The shape settings in use (YAML-ready), e.g. ``{"width": 0.01}``."""
        ...

    def candidates(self, speed_noise: np.ndarray) -> tuple[FrictionLaw, ...]:
        """The concrete laws to choose from by cross-validation: ``(self,)`` for a fixed law.

        ``speed_noise`` (N_D,) is the noise of the joint-side drive speeds in the data (rad/s): laws
        whose width follows the encoder noise read it.
        """
        ...


class SignCoulomb:
    """The paper's law (eq. 5): ``FC·sign(v) + FV·v (+ FO)``; no shape setting."""

    name = "sign"
    extra_terms: tuple[DriveTerm, ...] = ()

    def coulomb_shape(self, v: np.ndarray) -> np.ndarray:
        """``sign(v)``."""
        return np.sign(v)

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """No term of its own."""
        raise KeyError(term)

    def settings(self) -> dict[str, Any]:
        """No shape setting."""
        return {}

    def candidates(self, speed_noise: np.ndarray) -> tuple[FrictionLaw, ...]:
        """Itself."""
        return (self,)

    def __repr__(self) -> str:
        return "SignCoulomb()"


class TanhCoulomb:
    """Coulomb friction smoothed through zero, ``FC·tanh(v/width) + FV·v``: the part the laws that
    smooth ``sign(v)`` share (``smooth``, ``asymmetric``, ``load``). ``width`` (rad/s, joint side):
    one value, or a grid chosen by block cross-validation; a law of its own adds its terms by
    overriding ``extra_terms`` and :meth:`extra_basis`."""

    name = "smooth"
    extra_terms: tuple[DriveTerm, ...] = ()

    def __init__(self, width: float | Sequence[float]) -> None:
        self.width = width
        self._widths = positive_widths(width, "width")

    def coulomb_shape(self, v: np.ndarray) -> np.ndarray:
        """``tanh(v/width)`` (the grid's first width until one is chosen)."""
        return np.tanh(v / self._widths[0])

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """No term of its own."""
        raise KeyError(term)

    def settings(self) -> dict[str, Any]:
        """``{"width": ε}`` (rad/s)."""
        return {"width": grid_setting(self._widths)}

    def candidates(self, speed_noise: np.ndarray) -> tuple[FrictionLaw, ...]:
        """One law of this kind per width of the grid."""
        return tuple(type(self)(w) for w in self._widths)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(width={self.width!r})"


def positive_widths(width: float | Sequence[float], what: str) -> tuple[float, ...]:
    """``width`` as a tuple of positive speeds (rad/s); a ValueError otherwise."""
    widths = tuple(float(w) for w in np.atleast_1d(np.asarray(width, dtype=float)))
    if not widths or not all(w > 0 and np.isfinite(w) for w in widths):
        raise ValueError(f"friction.{what} must be positive speeds (rad/s), got {list(widths)}")
    return widths


def grid_setting(values: tuple[float, ...]) -> float | list[float]:
    """A shape setting as a config holds it: one value, or the list of a grid (YAML-ready)."""
    return values[0] if len(values) == 1 else list(values)


def describe_law(law: FrictionLaw) -> str:
    """``smooth (width 0.01)``: the law and its shape settings (speeds in rad/s), for reports."""

    def value(v: Any) -> str:
        if isinstance(v, list | tuple) and len(v) > 3:  # one per drive: the range
            return f"{min(v):.3g}" if min(v) == max(v) else f"{min(v):.3g}…{max(v):.3g}"
        if isinstance(v, list | tuple):
            return "[" + ", ".join(f"{x:.3g}" for x in v) + "]"
        return f"{v:.3g}" if isinstance(v, float) else str(v)

    settings = law.settings()
    if not settings:
        return law.name
    return (
        f"{law.name} ({', '.join(f'{k.replace(chr(95), chr(32))} {value(v)}' for k, v in settings.items())})"
    )


def law_mapping(law: FrictionLaw) -> dict[str, Any]:
    """The law as a config mapping (``_target_`` and its settings): how an identified model stores it."""
    cls = type(law)
    return {"_target_": f"{cls.__module__}.{cls.__qualname__}", **law.settings()}


def law_from_mapping(mapping: Mapping[str, Any] | None) -> FrictionLaw:
    """The law a :func:`law_mapping` describes (None: the paper's); a ``ConfigError`` if it cannot
    be built."""
    if not mapping:
        return SignCoulomb()
    settings = dict(mapping)
    target = str(settings.pop("_target_", ""))
    module_name, _, class_name = target.rpartition(".")
    try:
        law = getattr(importlib.import_module(module_name), class_name)(**settings)
    except (ImportError, AttributeError, TypeError, ValueError) as error:
        raise ConfigError(f"friction law {target!r} with {settings}: {error}") from error
    if not isinstance(law, FrictionLaw):
        raise ConfigError(
            f"friction law {target!r} does not implement lwrlab.model.friction_laws.FrictionLaw"
        )
    return law


def term_definitions(law: FrictionLaw) -> dict[str, DriveTerm]:
    """Every term a robot with ``law`` may carry, by name."""
    return {**STANDARD_TERMS, **{t.name: t for t in law.extra_terms}}


def drifting_terms(law: FrictionLaw) -> tuple[DriveTerm, ...]:
    """The terms of a robot with ``law`` whose torque is friction that drifts (:attr:`DriveTerm.drifts`).

    Examples
    --------
    >>> [t.prefix for t in drifting_terms(SignCoulomb())]
    ['FC', 'FV']
    """
    return tuple(term for term in term_definitions(law).values() if term.drifts)


def has_memory(law: FrictionLaw) -> bool:
    """Whether the law's columns depend on the motion before each sample (friction that holds still):
    such a law offers ``history_basis(v, dt) -> {term: (N, N_D) columns}`` over a whole log's
    consecutive samples, and its ``coulomb_shape`` and ``extra_basis`` are memoryless approximations
    for single states."""
    return callable(getattr(law, "history_basis", None))


def history_columns(law: FrictionLaw, v: np.ndarray, dt: float) -> dict[str, np.ndarray] | None:
    """A law with memory: its columns over consecutive samples ``v`` (N, N_D) ``dt`` seconds apart,
    by term; None for a memoryless law."""
    if not has_memory(law):
        return None
    columns: dict[str, np.ndarray] = law.history_basis(v, dt)  # type: ignore[attr-defined]
    return columns


def largest_basis(law: FrictionLaw, term: str, speed: np.ndarray) -> np.ndarray:
    """The magnitude of the law's own ``term`` column at the drive speeds ``±speed`` (…, N_D), whichever
    direction is larger: what the term may hold at that speed (a Stribeck or breakaway excess)."""
    return np.maximum(np.abs(law.extra_basis(term, speed)), np.abs(law.extra_basis(term, -speed)))


def has_load(law: FrictionLaw) -> bool:
    """Whether the law has terms that grow with the torque each drive transmits (a Coulomb level that
    rises with the load of the gears): such a law offers ``load_basis(term, v, load) -> (N, N_D)``
    with ``load`` the drives' transmitted rigid-body torque (N·m, joint side), which the regressor
    gives from the robot's own inertial parameters; its ``extra_basis`` is the approximation without
    a load (zero)."""
    return callable(getattr(law, "load_basis", None))


def drive_loads(drive: Any, rigid_body: np.ndarray) -> np.ndarray:
    """(N, N_D) the torque each drive transmits (joint side, N·m) of joint torques ``rigid_body``
    (N, N_J): ``C⁻ᵀ·τ`` (the joint torques themselves for uncoupled drives)."""
    if drive is None or drive.is_direct:
        return np.asarray(rigid_body, dtype=float)
    return np.linalg.solve(drive.coupling.T, np.asarray(rigid_body, dtype=float).T).T


def history_window(
    history: dict[str, np.ndarray] | None, start: int, count: int
) -> dict[str, np.ndarray] | None:
    """The columns of :func:`history_columns` at the ``count`` samples from ``start`` (None: None)."""
    if history is None:
        return None
    return {term: values[start : start + count] for term, values in history.items()}


def drive_basis(
    law: FrictionLaw,
    term: str,
    v: np.ndarray,
    a: np.ndarray | None = None,
    history: dict[str, np.ndarray] | None = None,
    load: np.ndarray | None = None,
) -> np.ndarray:
    """The column of ``term`` for joint-side drive speeds ``v`` and accelerations ``a`` (N, N_D);
    ``history``: a memory law's columns at these samples (:func:`history_columns`), used where given;
    ``load``: the drives' transmitted torques (:func:`drive_loads`), for a law with load terms."""
    if history is not None and term in history:
        return history[term]
    if load is not None and has_load(law) and term in {t.name for t in law.extra_terms}:
        columns: np.ndarray = law.load_basis(term, v, load)  # type: ignore[attr-defined]
        return columns
    if term == "coulomb":
        return law.coulomb_shape(v)
    if term == "viscous":
        return v
    if term == "offset":
        return np.ones_like(v)
    if term == "rotor":
        if a is None:
            raise ValueError("the rotor-inertia columns need the accelerations")
        return a
    return law.extra_basis(term, v)
