"""A segment's wrench regressor as a constant linear map of the segment's state.

The Newton–Euler wrench of a segment about its frame origin is linear in its standard parameters
``[M, MSX, MSY, MSZ, XX, YY, ZZ, XY, XZ, YZ]``::

    f = M·a + (S(ω̇) + S(ω)²)·MS                 force rows:  columns M, MSX, MSY, MSZ
    n = −S(a)·MS + (L(ω̇) + S(ω)·L(ω))·I         moment rows: columns MSX … MSZ, XX … YZ

with L(w)·[XX, YY, ZZ, XY, XZ, YZ] = I·w. Every entry of this 6×10 matrix is a sum of at most two
components of the segment's *state* ``(ω, ω̇, a, vec(ωωᵀ))`` or their negatives, so the non-zero
blocks of many samples are one product of :data:`ENTRY_MAP` with their states (samples last).
"""

from __future__ import annotations

import re

import numpy as np

STATE = ("wx", "wy", "wz", "dx", "dy", "dz", "ax", "ay", "az", *(r + s for r in "xyz" for s in "xyz"))
"""A segment's state: ω (rad/s), ω̇ (rad/s²), the acceleration a of its origin (m/s², gravity
included) and the products ω_r·ω_s (rad²/s², "xy" = ω_x·ω_y), all in the segment's frame."""

# Rows n_x, n_y, n_z, f_x, f_y, f_z: the order of a twist (ω; v), whose dot product with the
# wrench (n; f) is a joint torque. Symbols of STATE, "0" for zero.
_FIRST_MOMENT_ENTRIES = (  # columns M, MSX, MSY, MSZ
    ("0", "0", "az", "-ay"),
    ("0", "-az", "0", "ax"),
    ("0", "ay", "-ax", "0"),
    ("ax", "-yy - zz", "xy - dz", "xz + dy"),
    ("ay", "xy + dz", "-xx - zz", "yz - dx"),
    ("az", "xz - dy", "yz + dx", "-xx - yy"),
)
_INERTIA_ENTRIES = (  # rows n_x, n_y, n_z (the force rows have no inertia columns); columns XX … YZ
    ("dx", "-yz", "yz", "dy - xz", "dz + xy", "yy - zz"),
    ("xz", "dy", "-xz", "dx + yz", "zz - xx", "dz - xy"),
    ("-xy", "xy", "dz", "xx - yy", "dx - yz", "dy + xz"),
)
_FIRST_MOMENT_COUNT = 6 * 4


def _coefficients(entry: str) -> np.ndarray:
    """The entry as a row of coefficients of the state: "xy - dz" → +1 at "xy", −1 at "dz"."""
    row = np.zeros(len(STATE))
    for sign, symbol in re.findall(r"([+-]?)\s*(\w+)", entry):
        if symbol != "0":
            row[STATE.index(symbol)] = -1.0 if sign == "-" else 1.0
    return row


ENTRY_MAP = np.array(
    [
        _coefficients(entry)
        for block in (_FIRST_MOMENT_ENTRIES, _INERTIA_ENTRIES)
        for row in block
        for entry in row
    ]
)
"""(42, 18) the non-zero blocks of the wrench regressor (:func:`wrench_blocks`) from the state."""
ENTRY_MAP.flags.writeable = False
assert not ENTRY_MAP[:, :3].any()  # Y depends on ω only through vec(ωωᵀ)


def state_rotation(rotation: np.ndarray) -> np.ndarray:
    """(18, 18) the change of a state's coordinates by a change of frame ``v ← Q·v`` (Q = ``rotation``).

    ω, ω̇ and a change as vectors; vec(ωωᵀ) as ``Q·ωωᵀ·Qᵀ``, i.e. by ``Q ⊗ Q``.
    """
    out = np.zeros((18, 18))
    for block in range(3):
        out[3 * block : 3 * block + 3, 3 * block : 3 * block + 3] = rotation
    out[9:, 9:] = np.kron(rotation, rotation)
    return out


def wrench_blocks(entries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Views of the wrench regressor ``ENTRY_MAP @ state`` held in ``entries`` (42, c), rows in twist order.

    Returns the (6, 4, c) block of the columns M, MSX, MSY, MSZ and the (3, 6, c) block of the
    moment rows, columns XX … YZ (the rest of the 6×10 matrix is zero).
    """
    c = entries.shape[1]
    return entries[:_FIRST_MOMENT_COUNT].reshape(6, 4, c), entries[_FIRST_MOMENT_COUNT:].reshape(3, 6, c)


def _wrench_basis() -> np.ndarray:
    """(15, 6, 10) ``C_m`` with ``Y = Σ_m t_m·C_m`` for ``t = (ω̇, a, vec(ωωᵀ))``: ENTRY_MAP as matrices.

    Y does not depend on ω itself (the first three components of the state), only through vec(ωωᵀ).
    """
    first_moment, inertia = wrench_blocks(np.asarray(ENTRY_MAP))  # the state's components last
    basis = np.zeros((6, 10, len(STATE)))
    basis[:, :4] = first_moment
    basis[:3, 4:] = inertia
    return np.ascontiguousarray(basis[..., 3:].transpose(2, 0, 1))


WRENCH_BASIS = _wrench_basis()
"""(15, 6, 10) constant matrices mapping ``(ω̇, a, vec(ωωᵀ))`` of a segment to its wrench regressor
(rows n then f, columns the standard parameters)."""
WRENCH_BASIS.flags.writeable = False
WRENCH_BASIS_FLAT = WRENCH_BASIS.reshape(15, 60)
""":data:`WRENCH_BASIS` with each matrix flattened row-major."""
