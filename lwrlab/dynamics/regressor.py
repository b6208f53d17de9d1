"""Batched joint-torque regressor ``W(q, q̇, q̈)`` with friction columns.

For N samples the regressor stacks the per-sample ``N_J × P`` matrices sample-major (rows
``k·N_J + j``), as in eq. (5) of Katsumata et al., so that ``W @ φ`` is the torque of every joint at
every sample; ``P = 10·N_L + (number of friction terms)·N_J`` in the column order of
:attr:`lwrlab.model.robot.RobotModel.parameter_names`.

Serial chains of revolute joints (every robot built from a DH table, most URDF arms) use a
vectorised Newton–Euler recursion over all samples at once (:func:`chain_inertial_regressor`) from
:data:`SMALL_BATCH` samples on. Smaller batches, and anything else, go through a loop over
Pinocchio's ``computeJointTorqueRegressor``.

How the vectorised recursion is laid out, and why (each point was measured with
``benchmarks/regressor.py`` and ``line_profiler``): a numpy call costs about a microsecond whatever
its size, numpy's batched products of tiny matrices are slow, and fresh memory costs a page fault
per 4 KiB, so

* the samples are the *last* axis of every working array (a vector of c samples is (3, c), the
  unit twists of j joints (2, 3, j, c)): every operation is one long contiguous loop;
* samples go through in chunks of :data:`CHUNK_SAMPLES`, in a workspace kept between calls;
* each joint turns about the z axis of an "axis frame" (the joint frame itself in DH models): the
  joint rotation is a few products with its cosine and sine, and everything constant (placement,
  lever arm, centripetal term) is a product with a small precomputed matrix;
* a segment's 6×10 wrench regressor is assembled from a table of its 39 non-zero entries, each one
  or two values of a per-segment table (ω, ω̇, a, ω_r·ω_s and their negatives);
* the torque of joint k due to segment j is the unit twist of joint k seen from segment j dotted
  with the segment's wrench regressor; the twists are carried forward with the recursion, so there
  is no backward pass and no transformation of 6×10 blocks;
* each chunk's regressor is assembled as [column, joint, sample] and written to the output, whose
  layout is [sample, joint, column], by one transposition.

In the recursion every sample goes through the same floating-point operations whatever the batch
around it, so a sample's regressor does not depend on the batch to the last bit: products with
constant matrices use ``np.einsum`` (BLAS picks kernels by size and position) and chunks have at
least 2 samples. Across :data:`SMALL_BATCH` the two engines agree to round-off (~1e-14 relative),
not to the last bit.
"""

from __future__ import annotations

import math
import re
import threading
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from lwrlab.model.inertia import PIN_TO_STANDARD
from lwrlab.model.robot import RobotModel

SMALL_BATCH = 128
"""Below this many samples a serial chain goes through the Pinocchio loop too: the vectorised
recursion costs ~0.4 ms whatever the batch (a few hundred numpy calls) and ~2 µs per sample, the loop
~5 µs per sample; on the LWR4 the two cross between 120 and 200 samples, depending on the load of
the machine (``benchmarks/regressor.py``)."""

CHUNK_SAMPLES = 1000
"""Samples per chunk of the vectorised recursion (a few MB of working arrays).

Larger chunks save numpy calls but the final transposition slows down once the chunk's regressor
(4.7 kB per sample for a 7-joint arm) no longer fits the cache.
"""

_AXES = {"RX": np.array([1.0, 0.0, 0.0]), "RY": np.array([0.0, 1.0, 0.0]), "RZ": np.array([0.0, 0.0, 1.0])}


# --- geometry of the chain ----------------------------------------------------------------------


def _skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices of (..., 3) vectors → (..., 3, 3): ``S(v)·w = v × w``."""
    s = np.zeros(v.shape[:-1] + (3, 3))
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
    return np.column_stack([u, _skew(axis) @ u, axis])


def _centripetal_coefficients(lever: np.ndarray) -> np.ndarray:
    """(…, 3, 9) C with ``ω × (ω × t) = (ωωᵀ − |ω|²·1)·t = C·vec(ωωᵀ)`` for lever arms t (…, 3)."""
    c = np.zeros(lever.shape[:-1] + (3, 9))
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
    velocity_maps: np.ndarray = field(init=False, repr=False, compare=False)
    """(N_J, 3, 6) ``[−E_jᵀ·S(t_j), E_jᵀ]``: the linear part v of a twist (ω; v) from the parent's axis
    frame to frame j′ before its joint turns (v moves from the parent's origin to ``t_j``: ``v + ω × t_j``);
    its angular part turns by E_jᵀ."""
    turns_t: np.ndarray = field(init=False, repr=False, compare=False)
    """(N_J, 3, 3) E_jᵀ: a vector from the parent's axis frame to frame j′ before its joint turns."""
    acceleration_maps: np.ndarray = field(init=False, repr=False, compare=False)
    """(N_J, 3, 15) the map of the parent's (ω̇; a; vec(ωωᵀ)) to the acceleration of the origin of
    frame j′ before its joint turns: ``E_jᵀ·(a + ω̇ × t_j + ω × (ω × t_j))``."""

    def __post_init__(self) -> None:
        key = b"".join(
            np.ascontiguousarray(x, dtype=float).tobytes()
            for x in (self.rotations, self.translations, self.axes)
        )
        if key not in _DERIVED:  # building them costs more than a small regressor: keep the last few
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
        shift = -turns_t @ _skew(levers)  # −E_jᵀ·S(t_j): v + ω × t = v − S(t)·ω
        acceleration_maps = np.concatenate(
            [shift, turns_t, turns_t @ _centripetal_coefficients(levers)], axis=2
        )
        derived = {
            "axis_frames": frames,
            "turns_axis": np.any(frames != np.eye(3), axis=(1, 2)),
            "velocity_maps": np.concatenate([shift, turns_t], axis=2),
            "turns_t": np.ascontiguousarray(turns_t),
            "acceleration_maps": acceleration_maps,
        }
        for value in derived.values():
            value.flags.writeable = False  # shared by every chain of this geometry
        return derived


_DERIVED: dict[bytes, dict[str, np.ndarray]] = {}
"""Derived constants of recently seen chain geometries, keyed by (rotations, translations, axes)."""


def serial_chain(model: pin.Model) -> SerialChain | None:
    """The chain's constant geometry, or None if ``model`` is not a serial chain of revolute joints."""
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


# --- a segment's value table and wrench regressor -------------------------------------------------

_STATE = ("wx", "wy", "wz", "dx", "dy", "dz", "ax", "ay", "az", *(r + s for r in "xyz" for s in "xyz"))
"""A segment's state, rows 1…18 of its value table: ω (rad/s), ω̇ (rad/s²), the acceleration a of
its origin (m/s², gravity included) and the products ω_r·ω_s (rad²/s², "xy" = ω_x·ω_y), all in the
segment's (axis) frame. Row 0 of the table is zero and rows 19…36 hold the negatives of the state."""
_TABLE_ROWS = 1 + 2 * len(_STATE)


def _complete_table(table: np.ndarray) -> None:
    """Fill rows 10… of a value table (37, c) from ω, ω̇ and a (rows 1…9); row 0 stays zero."""
    n = len(_STATE)
    w = table[1:4]
    np.multiply(w[:, None], w[None], out=table[10:19].reshape(3, 3, -1))
    np.negative(table[1 : 1 + n], out=table[1 + n :])


# Newton–Euler wrench of a segment about its frame origin, linear in its standard parameters:
#
#     f = M·a + (S(ω̇) + S(ω)²)·MS                 force rows:  columns M, MSX, MSY, MSZ
#     n = −S(a)·MS + (L(ω̇) + S(ω)·L(ω))·I         moment rows: columns MSX … MSZ, XX … YZ
#
# with L(w)·[XX, YY, ZZ, XY, XZ, YZ] = I·w. Every entry is a sum of at most two table values
# (symbols of _STATE). The force rows have no inertia columns and the moment rows no mass column.
_MASS_ENTRIES = ("ax", "ay", "az")
_FIRST_MOMENT_ENTRIES = (  # rows n_x, n_y, n_z, f_x, f_y, f_z (the order of a twist (ω; v)); columns MSX, MSY, MSZ
    ("0", "az", "-ay"),
    ("-az", "0", "ax"),
    ("ay", "-ax", "0"),
    ("-yy - zz", "xy - dz", "xz + dy"),
    ("xy + dz", "-xx - zz", "yz - dx"),
    ("xz - dy", "yz + dx", "-xx - yy"),
)
_INERTIA_ENTRIES = (  # rows n_x, n_y, n_z; columns XX, YY, ZZ, XY, XZ, YZ
    ("dx", "-yz", "yz", "dy - xz", "dz + xy", "yy - zz"),
    ("xz", "dy", "-xz", "dx + yz", "zz - xx", "dz - xy"),
    ("-xy", "xy", "dz", "xx - yy", "dx - yz", "dy + xz"),
)


class _Wrench(NamedTuple):
    """The non-zero blocks of a segment's wrench regressor ``Y`` (6×10 per sample), each (…, c)."""

    mass: np.ndarray
    """(3, c) column M of the force rows (m/s²)."""
    inertia_diagonal: np.ndarray
    """(3, 3, c) columns XX, YY, ZZ of the moment rows (rad/s²)."""
    first_moment: np.ndarray
    """(6, 3, c) columns MSX, MSY, MSZ of the moment rows (m/s²) then of the force rows (rad/s²)."""
    inertia_products: np.ndarray
    """(3, 3, c) columns XY, XZ, YZ of the moment rows (rad/s²)."""


_WRENCH_ENTRIES = _Wrench(
    mass=_MASS_ENTRIES,
    inertia_diagonal=tuple(e for row in _INERTIA_ENTRIES for e in row[:3]),
    first_moment=sum(_FIRST_MOMENT_ENTRIES, ()),
    inertia_products=tuple(e for row in _INERTIA_ENTRIES for e in row[3:]),
)
"""The 39 entries in memory order, which puts every entry of two terms last (the force rows of the
first moment, then the products of inertia): their second terms are added in one slice."""
_WRENCH_SHAPES = _Wrench((3,), (3, 3), (6, 3), (3, 3))
_WRENCH_OFFSETS = np.cumsum([0] + [len(entries) for entries in _WRENCH_ENTRIES]).tolist()


def _table_rows(entry: str) -> tuple[int, int]:
    """Rows of the value table whose sum is ``entry`` ("xy - dz" → rows of +xy and −dz; "0" → 0, 0)."""
    rows = [0, 0]
    for i, (sign, symbol) in enumerate(re.findall(r"([+-]?)\s*(\w+)", entry)):
        if symbol != "0":
            rows[i] = 1 + _STATE.index(symbol) + (len(_STATE) if sign == "-" else 0)
    return rows[0], rows[1]


_ENTRY_ROWS = np.array([_table_rows(entry) for entry in sum(_WRENCH_ENTRIES, ())]).T.copy()
"""(2, 39) rows of the value table holding the two terms of each entry (row 0: zero)."""
_TWO_TERMS = int(np.argmax(_ENTRY_ROWS[1] > 0))
"""Index of the first entry with a second term: every later one has one, no earlier one has."""
assert np.all(_ENTRY_ROWS[1, :_TWO_TERMS] == 0) and np.all(_ENTRY_ROWS[1, _TWO_TERMS:] > 0)


_OWN_JOINT_ENTRIES = np.array(
    [_WRENCH_OFFSETS[2] + 6 + i for i in range(3)]  # first moment, moment row z
    + [_WRENCH_OFFSETS[1] + 6 + i for i in range(3)]  # XX, YY, ZZ, moment row z
    + [_WRENCH_OFFSETS[3] + 6 + i for i in range(3)]  # XY, XZ, YZ, moment row z
)
"""Entries of the moment row z, columns MSX … YZ: the torque of a joint turning about z on its own segment."""


def _wrench_views(entries: np.ndarray) -> _Wrench:
    """The blocks of a wrench regressor stored in ``entries`` (39, c), as views."""
    blocks = zip(_WRENCH_OFFSETS[:-1], _WRENCH_OFFSETS[1:], _WRENCH_SHAPES, strict=True)
    return _Wrench(*(entries[start:stop].reshape(*shape, entries.shape[1]) for start, stop, shape in blocks))


def _fill_wrench_regressor(table: np.ndarray, entries: np.ndarray) -> None:
    """A segment's wrench regressor from its value table (37, c), into ``entries`` (39, c)."""
    np.take(table, _ENTRY_ROWS[0], axis=0, out=entries, mode="clip")
    entries[_TWO_TERMS:] += table[_ENTRY_ROWS[1, _TWO_TERMS:]]


# --- the recursion --------------------------------------------------------------------------------


def _turn_about_z(vectors: np.ndarray, cos: np.ndarray, sin: np.ndarray, scratch: np.ndarray) -> None:
    """In place, vectors re-expressed in the frame turned by ``Rz(q)``: ``v ← Rz(q)ᵀ·v``.

    ``vectors`` has its (x, y, z) components on the first axis and samples on the last; ``cos``,
    ``sin`` (c,) broadcast; ``scratch`` is a flat array of at least 4/3 the size of ``vectors``.
    ``(x, y) ← (cos·x + sin·y, cos·y − sin·x)``.
    """
    xy, yx = vectors[:2], vectors[1::-1]
    cos_xy, sin_yx = scratch[: 2 * xy.size].reshape((2, *xy.shape))
    np.multiply(xy, cos, out=cos_xy)
    np.multiply(yx, sin, out=sin_yx)
    np.add(cos_xy[0], sin_yx[0], out=xy[0])
    np.subtract(cos_xy[1], sin_yx[1], out=xy[1])


def _cos_sin(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """cos and sin of ``angles`` (rad) from ``t = tan(q/2)``: ``((1 − t²), 2t) / (1 + t²)``.

    numpy evaluates tan with SIMD instructions but, for accuracy, not float64 sin and cos: one tan
    and a few products are about 7 times faster than sin and cos (AVX-512), within 2.3e-16.
    """
    t = np.tan(0.5 * angles)
    t_squared = t * t
    scale = 1.0 / (1.0 + t_squared)
    return (1.0 - t_squared) * scale, (t + t) * scale


def _next_state(
    chain: SerialChain,
    j: int,
    parent: np.ndarray,
    out: np.ndarray,
    cos: np.ndarray,
    sin: np.ndarray,
    rate: np.ndarray,
    accel: np.ndarray,
    scratch: np.ndarray,
) -> None:
    """Forward Newton–Euler step: value table of segment j−1 → of segment j (axis frames), into ``out``.

    ``ω_j = Rᵀω + q̇·z``, ``ω̇_j = Rᵀω̇ + q̈·z + (Rᵀω) × q̇·z``, ``a_j = Rᵀ(a + ω̇ × t + ω × (ω × t))``
    with ``R = E_j·Rz(q_j)``, t the lever arm and z = e_z the joint axis.
    """
    # The constant part, E_jᵀ and the lever arm (einsum, not BLAS: see the module docstring).
    np.einsum("ij,vjc->vic", chain.turns_t[j], parent[1:7].reshape(2, 3, -1), out=out[1:7].reshape(2, 3, -1))
    np.einsum("ij,jc->ic", chain.acceleration_maps[j], parent[4:19], out=out[7:10])
    motion = out[1:10].reshape(3, 3, -1)  # (ω, ω̇, a) × (x, y, z)
    _turn_about_z(motion.transpose(1, 0, 2), cos, sin, scratch)
    w, dw = motion[0], motion[1]
    coupling = scratch[: 2 * len(rate)].reshape(2, -1)  # (Rᵀω) × q̇·e_z = q̇·(ω_y, −ω_x, 0)
    np.multiply(w[1::-1], rate, out=coupling)
    dw[0] += coupling[0]
    dw[1] -= coupling[1]
    dw[2] += accel
    w[2] += rate
    _complete_table(out)


def _next_twists(
    chain: SerialChain,
    j: int,
    twists: np.ndarray,
    out: np.ndarray,
    cos: np.ndarray,
    sin: np.ndarray,
    scratch: np.ndarray,
) -> None:
    """Unit twists (ω; v) of joints 0…j−1 seen from axis frame j−1 → from axis frame j, plus joint j's own.

    ``twists`` and ``out`` are (2, 3, N_J, c); slots 0…j−1 are read, 0…j written. A twist moves like
    a velocity: ``ω ← Rᵀω``, ``v ← Rᵀ(v + ω × t)``; joint j's own is (e_z; 0) in its axis frame.
    """
    if j > 0:
        np.einsum(
            "ij,jc->ic", chain.turns_t[j], twists[0, :, :j].reshape(3, -1), out=out[0, :, :j].reshape(3, -1)
        )
        np.einsum(
            "ij,jc->ic",
            chain.velocity_maps[j],
            twists[:, :, :j].reshape(6, -1),
            out=out[1, :, :j].reshape(3, -1),
        )
        _turn_about_z(out[:, :, :j].transpose(1, 0, 2, 3), cos, sin, scratch)
    out[:, :, j] = 0.0
    out[0, 2, j] = 1.0


def _project(twists: np.ndarray, wrench: _Wrench, out: np.ndarray) -> None:
    """Torques of the joints with unit twists (ω; v) (2, 3, m, c) due to one segment, into ``out`` (10, m, c).

    Joint k feels ``τ_k = z_k·(n + (o − o_k) × f) = v_k·f + ω_k·n`` with ``v_k = z_k × (o − o_k)``: the
    unit twist of joint k at the segment's origin o, dotted with the segment's wrench (f; n) about o.
    """
    w, v = twists
    np.einsum("rkc,rc->kc", v, wrench.mass, out=out[0])
    np.einsum("rkc,rpc->pkc", twists.reshape(6, *twists.shape[2:]), wrench.first_moment, out=out[1:4])
    np.einsum("rkc,rpc->pkc", w, wrench.inertia_diagonal, out=out[4:7])
    np.einsum("rkc,rpc->pkc", w, wrench.inertia_products, out=out[7:])


def _project_own_joint(axis: np.ndarray, wrench: _Wrench, out: np.ndarray) -> None:
    """Torque of a segment's own joint, unit twist (axis; 0), into ``out`` (10, c): ``axis·n``.

    Its mass column stays zero: a force through the joint axis has no moment about it. (For a joint
    turning about the frame's z axis this is the moment row z: see ``_OWN_JOINT_ENTRIES``.)
    """
    blocks = (wrench.first_moment[:3], wrench.inertia_diagonal, wrench.inertia_products)
    for block, columns in zip(blocks, (slice(1, 4), slice(4, 7), slice(7, 10)), strict=True):
        np.einsum("r,rpc->pc", axis, block, out=out[columns])


class _Workspace:
    """The recursion's arrays for an N_J-joint chain, P columns and chunks of up to ``capacity`` samples.

    It is kept between calls (one per thread, see :func:`_workspace`): fresh memory costs a page
    fault per 4 KiB on first touch, which costs more than the arithmetic done on it. Each array is a
    flat buffer viewed for the chunk at hand, so that it is contiguous whatever the chunk's size.
    """

    def __init__(self, n: int, n_columns: int, capacity: int) -> None:
        self.n, self.n_columns, self.capacity = n, n_columns, capacity
        self._buffers = {
            name: np.empty(capacity * math.prod(shape)) for name, shape in self._shapes(1).items()
        }
        self._zeroed_for = 0  # the chunk size for which "rows" holds the regressor's constant zeros

    def _shapes(self, c: int) -> dict[str, tuple[int, ...]]:
        n = self.n
        return {
            "tables": (2, _TABLE_ROWS, c),  # value tables of a segment and of the next one
            "seen_table": (_TABLE_ROWS, c),  # a value table in joint-frame coordinates
            "twists": (2, 2, 3, n, c),  # unit twists (ω; v) of joints 0…j, and the next ones
            "seen_twists": (2, 3, n, c),  # the twists in joint-frame coordinates
            "scratch": (max(12, 8 * n) * c,),  # for _turn_about_z
            "entries": (_ENTRY_ROWS.shape[1], c),  # a wrench regressor (see _WRENCH_ENTRIES)
            "rows": (self.n_columns, n, c),  # the chunk's regressor, [column, joint, sample]
        }

    def arrays(self, c: int) -> dict[str, np.ndarray]:
        """Contiguous views for a chunk of c ≤ capacity samples.

        "rows" is zero wherever the regressor is zero whatever the state (segment j < k on joint k,
        mass column of a joint's own segment, friction of other joints) and so is row 0 of the value
        tables; everything else is undefined.
        """
        arrays = {
            name: self._buffers[name][: math.prod(shape)].reshape(shape)
            for name, shape in self._shapes(c).items()
        }
        arrays["wrench"] = _wrench_views(arrays["entries"])
        if self._zeroed_for != c:
            arrays["rows"].fill(0.0)
            arrays["tables"][:, 0] = arrays["seen_table"][0] = 0.0
            self._zeroed_for = c
        return arrays


_thread_state = threading.local()


def _workspace(n: int, n_columns: int) -> _Workspace:
    """This thread's workspace for N_J-joint chains and regressors of ``n_columns`` columns.

    One per thread: numpy releases the GIL, so threads must not share one.
    """
    spaces = _thread_state.__dict__.setdefault("workspaces", {})
    key = (n, n_columns)
    if key not in spaces or spaces[key].capacity <= CHUNK_SAMPLES:
        if len(spaces) >= 4:  # a few MB each: keep those of the robots in use
            spaces.pop(next(iter(spaces)))
        spaces[key] = _Workspace(n, n_columns, CHUNK_SAMPLES + 1)
    return spaces[key]


def _chunk_regressor(
    chain: SerialChain,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    terms: tuple[str, ...],
    out: np.ndarray,
    work: _Workspace,
) -> None:
    """Write the regressor of c samples (q, dq, ddq (c, N_J)) into ``out`` (m ≤ c, N_J, P), contiguous.

    The columns are the inertial ones of every segment, then the friction ``terms``; the first m
    samples go into ``out`` (the others pad the last chunk of a call).
    """
    c, n = q.shape
    arrays = work.arrays(c)
    cos, sin = _cos_sin(np.ascontiguousarray(q.T))
    rates, accels = np.ascontiguousarray(dq.T), np.ascontiguousarray(ddq.T)
    child, parent = arrays["tables"]
    parent[1:19] = 0.0  # the base: at rest, but accelerating upwards so that gravity acts on every segment
    parent[7:10] = -chain.gravity[:, None]
    twists, next_twists = arrays["twists"]
    rows, scratch, entries, wrench = arrays["rows"], arrays["scratch"], arrays["entries"], arrays["wrench"]
    joints = np.arange(n)
    for t, term in enumerate(terms):
        rows[10 * n + t * n + joints, joints] = _FRICTION_BASIS[term](rates)
    for j in range(n):
        _next_state(chain, j, parent, child, cos[j], sin[j], rates[j], accels[j], scratch)
        _next_twists(chain, j, twists, next_twists, cos[j], sin[j], scratch)
        parent, child, twists, next_twists = child, parent, next_twists, twists
        table, seen_twists = parent, twists[:, :, :j]
        if chain.turns_axis[j]:  # from axis-frame to joint-frame coordinates, where φ_j is expressed
            frame = chain.axis_frames[j]
            table = arrays["seen_table"]
            np.einsum("ij,vjc->vic", frame, parent[1:10].reshape(3, 3, c), out=table[1:10].reshape(3, 3, c))
            _complete_table(table)
            seen_twists = arrays["seen_twists"][:, :, :j]
            np.einsum(
                "ij,vjc->vic", frame, twists[:, :, :j].reshape(2, 3, -1), out=seen_twists.reshape(2, 3, -1)
            )
        _fill_wrench_regressor(table, entries)
        _project(seen_twists, wrench, rows[10 * j : 10 * j + 10, :j])
        if chain.turns_axis[j]:
            _project_own_joint(chain.axes[j], wrench, rows[10 * j : 10 * j + 10, j])
        else:
            rows[10 * j + 1 : 10 * j + 10, j] = entries[_OWN_JOINT_ENTRIES]
    # [column, joint, sample] → [sample, joint, column], in one pass (einsum writes [column, joint, sample]
    # blocks faster than [joint, column, sample] ones, and the transposition costs the same).
    out[...] = rows[:, :, : len(out)].transpose(2, 1, 0)


def _chunk_size(n_samples: int) -> int:
    """Near-equal chunks of at most about :data:`CHUNK_SAMPLES` samples, at least 2, never a multiple of 512.

    At least 2 samples: with one, ``np.einsum`` turns its loops around and sums in another order, and
    a sample's regressor must not depend on the batch it comes in (to the last bit). Not a multiple
    of 512: rows of the workspace 4 KiB apart alias in the cache and slow the final transposition.
    """
    count = -(-n_samples // CHUNK_SAMPLES)
    size = max(2, -(-n_samples // max(count, 1)))
    return size + 1 if size % 512 == 0 else size


def _fill_chain_regressor(
    chain: SerialChain,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    terms: tuple[str, ...],
    out: np.ndarray,
) -> None:
    """The regressor of a serial revolute chain, inertial then friction ``terms`` columns, into ``out``.

    ``out`` is a contiguous (N, N_J, P) array; it is computed chunk by chunk (:func:`_chunk_regressor`),
    all of one size: the last one is padded with zero states, so the workspace keeps its layout.
    """
    if not q.shape == dq.shape == ddq.shape:
        raise ValueError(f"q, dq and ddq must have one shape, got {q.shape}, {dq.shape} and {ddq.shape}")
    n_samples, n = q.shape
    size = _chunk_size(n_samples)
    work = _workspace(n, out.shape[2])
    for start in range(0, n_samples, size):
        stop = min(start + size, n_samples)
        states = [x[start:stop] for x in (q, dq, ddq)]
        if stop - start < size:
            states = [np.concatenate([x, np.zeros((size - (stop - start), n))]) for x in states]
        _chunk_regressor(chain, *states, terms, out[start:stop], work)


def chain_inertial_regressor(
    chain: SerialChain, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> np.ndarray:
    """Inertial regressor of a serial revolute chain, shape (N, N_J, 10·N_J).

    A forward Newton–Euler recursion over all samples at once gives each segment's angular velocity
    ω, angular acceleration ω̇ and the linear acceleration a of its frame origin (gravity enters as a
    base acceleration −g), all in the segment frame. The segment's wrench about its origin is linear
    in its 10 parameters, ``[f; n] = Y_j·φ_j`` (see ``_FIRST_MOMENT_ENTRIES``), and joint k ≤ j feels
    ``τ_k = u_kjᵀ·Y_j·φ_j``, with ``u_kj`` the unit twist of joint k seen from segment j's origin,
    carried forward along the recursion.

    q, dq, ddq: joint positions (rad), velocities (rad/s), accelerations (rad/s²), shape (N, N_J).
    """
    n_samples, n = q.shape
    out = np.empty((n_samples, n, 10 * n))
    _fill_chain_regressor(chain, q, dq, ddq, (), out)
    return out


def loop_inertial_regressor(
    model: pin.Model, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    """Inertial regressor by one ``pin.computeJointTorqueRegressor`` call per sample (any model).

    ``out``: an (N, N_J, 10·N_L) array (a view will do) to write into; a new one if None.
    """
    data = model.createData()
    regress = pin.computeJointTorqueRegressor
    n_samples, n_columns = len(q), 10 * (model.njoints - 1)
    # Pinocchio's rows land in a buffer kept between calls (fresh memory costs a page fault per
    # 4 KiB, about as much as the calls themselves for small batches), then are permuted to the
    # standard order by np.take on rows of 10 (indexing the last axis of a 4-D array is 10× slower).
    pinocchio_order = _loop_buffer(n_samples * model.nv * n_columns).reshape(n_samples, model.nv, n_columns)
    for k, state in enumerate(zip(q, dq, ddq)):
        pinocchio_order[k] = regress(model, data, *state)
    out = np.empty((n_samples, model.nv, n_columns)) if out is None else out
    np.take(
        pinocchio_order.reshape(n_samples, model.nv, -1, 10),
        PIN_TO_STANDARD,
        axis=3,
        out=out.reshape(n_samples, model.nv, -1, 10),
    )
    return out


def _loop_buffer(size: int) -> np.ndarray:
    """This thread's scratch of at least ``size`` floats for :func:`loop_inertial_regressor` (kept up to 1 MB)."""
    buffer = _thread_state.__dict__.get("loop_buffer")
    if buffer is None or buffer.size < size:
        buffer = np.empty(size)
        if size <= 1 << 17:
            _thread_state.loop_buffer = buffer
    return buffer[:size]


_FRICTION_BASIS = {"coulomb": np.sign, "viscous": lambda v: v, "offset": np.ones_like}
"""Friction basis functions of q̇ (rad/s): sign(q̇), q̇, 1."""


def _fill_friction_regressor(dq: np.ndarray, terms: tuple[str, ...], out: np.ndarray) -> None:
    """Write the friction columns (diagonal blocks) into ``out`` (N, N_J, len(terms)·N_J), zero elsewhere."""
    n = dq.shape[1]
    diag = np.arange(n)
    for t, term in enumerate(terms):
        out[:, diag, t * n + diag] = _FRICTION_BASIS[term](dq)


def friction_regressor(dq: np.ndarray, terms: tuple[str, ...]) -> np.ndarray:
    """Friction columns, shape (N, N_J, len(terms)·N_J): diagonal blocks of sign(q̇), q̇ or 1."""
    n_samples, n = dq.shape
    out = np.zeros((n_samples, n, len(terms) * n))
    _fill_friction_regressor(dq, terms, out)
    return out


def _as_samples(x: np.ndarray, n: int, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    x = x.reshape(1, -1) if x.ndim == 1 else x
    if x.ndim != 2 or x.shape[1] != n:
        raise ValueError(f"{name} must have shape (N, {n}), got {x.shape}")
    return x


def regressor(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, *, stacked: bool = True
) -> np.ndarray:
    """The full regressor ``W`` so that ``W @ robot.parameters`` is the joint torque (N·m).

    Parameters
    ----------
    robot : the robot (its friction terms select the friction columns).
    q, dq, ddq : joint positions (rad), velocities (rad/s), accelerations (rad/s²), shape (N, N_J).
    stacked : if True return (N·N_J, P) sample-major; otherwise (N, N_J, P).

    Examples
    --------
    >>> from lwrlab.model.description import load_robot_yaml  # doctest: +SKIP
    >>> W = regressor(robot, q, dq, ddq)           # doctest: +SKIP
    >>> np.allclose(W @ robot.parameters, robot.inverse_dynamics(q, dq, ddq).ravel())  # doctest: +SKIP
    True
    """
    n = robot.n_joints
    q, dq, ddq = (_as_samples(x, n, name) for x, name in ((q, "q"), (dq, "dq"), (ddq, "ddq")))
    n_inertial = 10 * robot.n_links
    chain = (
        serial_chain(robot.model) if q.shape[0] >= SMALL_BATCH else None
    )  # tens of µs: cheaper than caching on a mutable model
    if chain is not None:
        full = np.empty((q.shape[0], n, n_inertial + robot.n_friction))
        _fill_chain_regressor(chain, q, dq, ddq, robot.friction_terms, full)
    else:
        full = np.empty((q.shape[0], n, n_inertial + robot.n_friction))
        loop_inertial_regressor(robot.model, q, dq, ddq, out=full[:, :, :n_inertial])
        full[:, :, n_inertial:] = 0.0
        _fill_friction_regressor(dq, robot.friction_terms, full[:, :, n_inertial:])
    return full.reshape(-1, full.shape[2]) if stacked else full
