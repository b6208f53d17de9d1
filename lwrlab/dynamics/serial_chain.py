"""Constant geometry of a serial chain of revolute joints, and the constants of its vectorised recursion.

:func:`serial_chain` reads a Pinocchio model into a :class:`SerialChain` (per joint: placement in the
parent frame and unit axis), or returns None for anything else (trees, prismatic or free joints).
The chain derives, once per geometry, the constant matrices that the Newton–Euler recursion of
:mod:`lwrlab.dynamics.chain_regressor` applies to all samples at once.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from lwrlab.dynamics.segment_wrench import ENTRY_MAP, state_rotation

_AXES = {"RX": np.array([1.0, 0.0, 0.0]), "RY": np.array([0.0, 1.0, 0.0]), "RZ": np.array([0.0, 0.0, 1.0])}


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices of (..., 3) vectors → (..., 3, 3): ``S(v)·w = v × w``."""
    s = np.zeros((*v.shape[:-1], 3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def _axis_frame(axis: np.ndarray) -> np.ndarray:
    """A rotation Q with ``Q·e_z = axis`` (unit); the identity when the axis is e_z."""
    if axis[0] == 0.0 and axis[1] == 0.0 and axis[2] > 0.0:
        return np.eye(3)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = helper - (helper @ axis) * axis
    u /= np.linalg.norm(u)
    return np.column_stack([u, skew(axis) @ u, axis])


def _centripetal_coefficients(lever: np.ndarray) -> np.ndarray:
    """(…, 3, 9) C with ``ω × (ω × t) = (ωωᵀ − |ω|²·1)·t = C·vec(ωωᵀ)`` for lever arms t (…, 3)."""
    c = np.zeros((*lever.shape[:-1], 3, 9))
    for i in range(3):
        c[..., i, 3 * i : 3 * i + 3] += lever  # (ωωᵀ·t)_i = Σ_s ω_i·ω_s·t_s
        c[..., i, [0, 4, 8]] -= lever[..., i, None]  # |ω|²·t_i
    return c


@dataclass(frozen=True)
class SerialChain:
    """Constant geometry of a serial revolute chain: per joint, its placement in the parent frame and axis.

    For the recursion, joint frame j is paired with its *axis frame* j′, the same frame turned by a
    constant rotation Q_j with ``Q_j·e_z = axis_j`` (Q_j = 1 for the z joints of DH models), so that
    every joint turns about the z axis of its axis frame. Seen from the parent's axis frame, frame j′
    has its origin at ``t_j = Q_{j-1}ᵀ·p_j`` and the orientation ``E_j·Rz(q_j)`` with the constant
    ``E_j = Q_{j-1}ᵀ·R_j·Q_j`` (Q_0 = 1: the base frame). The derived fields hold the constants of
    that recursion.
    """

    rotations: np.ndarray
    """(N_J, 3, 3) rotation R_j of each joint frame at q = 0 in its parent frame."""
    translations: np.ndarray
    """(N_J, 3) origin p_j of each joint frame in its parent frame (m)."""
    axes: np.ndarray
    """(N_J, 3) unit joint axis in the joint frame."""
    gravity: np.ndarray
    """Gravity in the base frame (m/s²)."""

    axis_frames: np.ndarray = field(init=False, repr=False, compare=False)
    """(N_J, 3, 3) Q_j: from axis-frame to joint-frame coordinates."""
    turns_axis: np.ndarray = field(init=False, repr=False, compare=False)
    """(N_J,) bool: whether Q_j is not the identity (the joint does not turn about its frame's z)."""
    state_maps: np.ndarray = field(init=False, repr=False, compare=False)
    """(N_J, 9, 18) the map of the parent's state (ω, ω̇, a, vec(ωωᵀ)) in its axis frame to
    ``(E_jᵀ·ω, E_jᵀ·ω̇, E_jᵀ·(a + ω̇ × t_j + ω × (ω × t_j)))``: the segment's state before its joint
    turns and moves (the first segment's comes from the base: :attr:`base_state`)."""
    base_state: np.ndarray = field(init=False, repr=False, compare=False)
    """(9,) the first segment's state before its joint turns: at rest, accelerating by −g."""
    twist_maps: np.ndarray = field(init=False, repr=False, compare=False)
    """(N_J, 6, 6) ``[[E_jᵀ, 0], [−E_jᵀ·S(t_j), E_jᵀ]]``: a twist (ω; v) from the parent's axis frame
    to frame j′ before its joint turns (v moves from the parent's origin to t_j: ``v + ω × t_j``)."""
    entry_maps: np.ndarray = field(init=False, repr=False, compare=False)
    """(N_J, 42, 15) the non-zero blocks of segment j's wrench regressor (in joint-frame coordinates,
    where its parameters are expressed) from its state (ω̇, a, vec(ωωᵀ)) in axis-frame coordinates
    (:data:`~lwrlab.dynamics.segment_wrench.ENTRY_MAP` after the change of frame by Q_j, without its
    columns of ω, which are zero)."""

    def __post_init__(self) -> None:
        key = b"".join(
            np.ascontiguousarray(x, dtype=float).tobytes()
            for x in (self.rotations, self.translations, self.axes, self.gravity)
        )
        if key not in _DERIVED:  # building them costs about as much as a small regressor: keep the last few
            if len(_DERIVED) >= 16:
                _DERIVED.pop(next(iter(_DERIVED)))
            _DERIVED[key] = self._derive()
        for name, value in _DERIVED[key].items():
            object.__setattr__(self, name, value)

    def _derive(self) -> dict[str, np.ndarray]:
        n = len(self.axes)
        frames = np.array([_axis_frame(axis) for axis in self.axes]).reshape(n, 3, 3)
        parents_t = np.concatenate([np.eye(3)[None], frames[:-1]]).transpose(0, 2, 1)[:n]
        turns_t = (parents_t @ self.rotations @ frames).transpose(0, 2, 1)  # E_jᵀ
        levers = (parents_t @ self.translations[..., None])[..., 0]  # t_j
        shift = -turns_t @ skew(levers)  # −E_jᵀ·S(t_j): v + ω × t = v − S(t)·ω
        state_maps = np.zeros((n, 9, 18))
        state_maps[:, 0:3, 0:3] = state_maps[:, 3:6, 3:6] = state_maps[:, 6:9, 6:9] = turns_t
        state_maps[:, 6:9, 3:6] = shift
        state_maps[:, 6:9, 9:18] = turns_t @ _centripetal_coefficients(levers)
        twist_maps = np.zeros((n, 6, 6))
        twist_maps[:, :3, :3] = twist_maps[:, 3:, 3:] = turns_t
        twist_maps[:, 3:, :3] = shift
        base_state = np.zeros(9)
        if n:
            base_state[6:9] = turns_t[0] @ -np.asarray(self.gravity, dtype=float)
        derived = {
            "axis_frames": frames,
            "turns_axis": np.any(frames != np.eye(3), axis=(1, 2)),
            "state_maps": state_maps,
            "base_state": base_state,
            "twist_maps": twist_maps,
            "entry_maps": np.array(
                [ENTRY_MAP[:, 3:] @ state_rotation(frame)[3:, 3:] for frame in frames]
            ).reshape(n, 42, 15),
        }
        for value in derived.values():
            value.flags.writeable = False  # shared by every chain of this geometry
        return derived


_DERIVED: dict[bytes, dict[str, np.ndarray]] = {}
"""Derived constants of recently seen chain geometries, keyed by (rotations, translations, axes, gravity)."""


def serial_chain(model: pin.Model) -> SerialChain | None:
    """The chain's constant geometry, or None if ``model`` is not a serial chain of revolute joints.

    A model's geometry is read once and kept while the model lives (reading it through Pinocchio's
    bindings costs ~50 µs, a sixth of a 100-sample regressor): models are built once (a joint added
    later is seen) and not changed in place, but for their inertias, which the chain does not hold
    (``RobotModel.with_parameters`` copies the model).
    """
    cached = _CHAINS.get(id(model))
    if cached is not None and cached[1] == model.njoints and cached[0]() is model:
        return cached[2]
    chain = _read_serial_chain(model)
    if len(_CHAINS) >= 64:  # forget the models that are gone
        for key in [key for key, (ref, _, _) in _CHAINS.items() if ref() is None]:
            del _CHAINS[key]
    _CHAINS[id(model)] = weakref.ref(model), model.njoints, chain
    return chain


_CHAINS: dict[int, tuple[weakref.ref[pin.Model], int, SerialChain | None]] = {}
"""The chains of the models seen, keyed by ``id(model)``, with a weak reference to tell a model
from a later one at the same address and the number of joints it had (a model being built)."""


def _read_serial_chain(model: pin.Model) -> SerialChain | None:
    """:func:`serial_chain`, read from the model."""
    rotations, translations, axes = [], [], []
    joints, parents, placements = model.joints, model.parents, model.jointPlacements
    for j in range(1, model.njoints):
        joint = joints[j]
        kind = joint.shortname().removeprefix("JointModel")
        if parents[j] != j - 1:
            return None
        if kind in _AXES:
            axis = _AXES[kind]
        elif kind == "RevoluteUnaligned":
            axis = np.asarray(joint.extract().axis, dtype=float)
            axis = axis / np.linalg.norm(axis)
        else:
            return None
        placement = placements[j]
        rotations.append(placement.rotation)
        translations.append(placement.translation)
        axes.append(axis)
    n = len(axes)
    return SerialChain(
        np.array(rotations).reshape(n, 3, 3),
        np.array(translations).reshape(n, 3),
        np.array(axes).reshape(n, 3),
        np.array(model.gravity.linear),
    )


def checked_serial_chain(model: pin.Model, needed_by: str) -> SerialChain:
    """:func:`serial_chain`, or a ValueError naming what needs one (``needed_by``)."""
    chain = serial_chain(model)
    if chain is None:
        raise ValueError(f"{needed_by} need a serial chain of revolute joints")
    return chain
