"""CDR bytes of the messages on the sample path, read and written without a generic serialiser.

Cyclone's Python serialiser walks a message's fields one by one (about 45 µs a JointState); at
1 kHz, with three messages out and one in per sample, that alone would take a fifth of a core. The
messages on the sample path have a fixed shape, so:

- :func:`decode_joint_state` reads a ``sensor_msgs/JointState``'s CDR bytes with ``struct`` and
  ``numpy.frombuffer``;
- :class:`StampedEncoder` writes a message whose only changing parts are its header stamp and its
  trailing float64 values (the external torques' JointState, a WrenchStamped): the bytes of a
  template message with those two parts replaced; :class:`JointStateEncoder` writes a robot's
  joint states (fixed names; positions, velocities and efforts) the same way;
- :class:`Float64ArrayEncoder` and :func:`decode_float64_array` write and read the
  ``std_msgs/Float64MultiArray`` joint commands a ``ros2_control`` forward controller takes.

Both equal Cyclone's own serialiser and ``rosbags``' (tests hold them so); the bytes go to DDS
and, unchanged, to the bag.
"""

from __future__ import annotations

import struct

import numpy as np

from lwrlab.live.messages import Float64MultiArray, Header, JointState, Time

ENCAPSULATION = b"\x00\x01\x00\x00"
"""CDR, little endian (XCDR1), as ROS 2 writes every message."""
_UINT32 = struct.Struct("<I")
_STAMP = struct.Struct("<iI")


class WireError(ValueError):
    """Bytes that are not the message they should be."""


def _string(data: memoryview, offset: int) -> tuple[str, int]:
    offset = (offset + 3) & ~3
    (length,) = _UINT32.unpack_from(data, offset)
    start = offset + 4
    end = start + length
    if length == 0 or end > len(data):
        raise WireError("a string runs past the message")
    return bytes(data[start : end - 1]).decode("utf-8"), end


def _doubles(data: memoryview, offset: int) -> tuple[np.ndarray, int]:
    offset = (offset + 3) & ~3
    (count,) = _UINT32.unpack_from(data, offset)
    offset += 4
    if count == 0:
        return np.zeros(0), offset
    offset = (offset + 7) & ~7
    end = offset + 8 * count
    if end > len(data):
        raise WireError("a float64 sequence runs past the message")
    return np.frombuffer(data, dtype="<f8", count=count, offset=offset).copy(), end


def decode_joint_state(raw: bytes) -> JointState:
    """A ``sensor_msgs/JointState`` of its CDR bytes (encapsulation header included); its arrays are
    numpy arrays. A :class:`WireError` for bytes that are not one."""
    if raw[:2] != ENCAPSULATION[:2]:
        raise WireError(f"not little-endian CDR (encapsulation {bytes(raw[:4]).hex()})")
    data = memoryview(raw)[4:]
    try:
        sec, nanosec = _STAMP.unpack_from(data, 0)
        frame, offset = _string(data, 8)
        offset = (offset + 3) & ~3
        (count,) = _UINT32.unpack_from(data, offset)
        offset += 4
        names = []
        for _ in range(count):
            name, offset = _string(data, offset)
            names.append(name)
        position, offset = _doubles(data, offset)
        velocity, offset = _doubles(data, offset)
        effort, offset = _doubles(data, offset)
    except struct.error as error:
        raise WireError(f"a JointState cut short: {error}") from error
    return JointState(Header(Time(sec, nanosec), frame), names, position, velocity, effort)  # type: ignore[arg-type]


class StampedEncoder:
    """The CDR bytes of ``template`` with another header stamp and other trailing float64 values.

    Parameters
    ----------
    template : a message whose first field is a header and whose last bytes are ``values`` float64
        values (a JointState with only efforts, a WrenchStamped): everything else stays as in it.
    values : how many float64 values end the message.
    """

    def __init__(self, template: object, values: int) -> None:
        raw = template.serialize()  # type: ignore[attr-defined]
        if raw[:4] != ENCAPSULATION:
            raise WireError("the template is not little-endian CDR")
        self.values = values
        # the header's stamp is the payload's first 8 bytes: what lies between it and the values stays
        self._middle = raw[12 : len(raw) - 8 * values]
        if (len(raw) - 4 - 8 * values) % 8:
            raise WireError("the template's trailing values are not float64-aligned")

    def encode(self, stamp_ns: int, values: np.ndarray) -> bytes:
        """The message's bytes at ``stamp_ns`` (ns) with ``values`` (float64, as many as the template's)."""
        array = np.ascontiguousarray(values, dtype="<f8")
        if array.size != self.values:
            raise ValueError(f"expected {self.values} values, got {array.size}")
        stamp = _STAMP.pack(stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000)
        return b"".join((ENCAPSULATION, stamp, self._middle, array.tobytes()))


class JointStateEncoder:
    """The CDR bytes of ``sensor_msgs/JointState`` messages of fixed joint names and frame: the header
    stamp, positions, velocities and efforts written into a template's bytes at their offsets.

    Parameters
    ----------
    names : the joints' names, every message's.
    frame : the header's frame.
    velocity : whether the messages carry velocities (else an empty array).
    """

    def __init__(self, names: list[str], frame: str = "", velocity: bool = True) -> None:
        n = len(names)
        arrays = [np.full(n, 1.0e300 + k * 1.0e290) if n else np.zeros(0) for k in range(3)]
        template = JointState(
            Header(Time(), frame),
            list(names),
            arrays[0].tolist(),
            arrays[1].tolist() if velocity else [],
            arrays[2].tolist(),
        )
        self._template = template.serialize()
        self._n = n
        # where each array's first value sits (after the encapsulation header)
        self._offsets = [
            self._template.index(array[:1].astype("<f8").tobytes()) if n else 0
            for array, kept in zip(arrays, (True, velocity, True), strict=True)
            if kept
        ]
        self.velocity = velocity

    def encode(
        self, stamp_ns: int, position: np.ndarray, velocity: np.ndarray | None, effort: np.ndarray
    ) -> bytes:
        """One message's bytes (``velocity`` ignored when the messages carry none)."""
        data = bytearray(self._template)
        data[4:12] = _STAMP.pack(stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000)
        values = [position, *([velocity] if self.velocity else []), effort]
        for offset, array in zip(self._offsets, values, strict=True):
            raw = np.ascontiguousarray(array, dtype="<f8")
            if raw.size != self._n:
                raise ValueError(f"expected {self._n} values, got {raw.size}")
            data[offset : offset + 8 * self._n] = raw.tobytes()
        return bytes(data)


class Float64ArrayEncoder:
    """The CDR bytes of a ``std_msgs/Float64MultiArray`` of ``count`` values and an empty layout (what
    a ``ros2_control`` forward controller's commands carry)."""

    def __init__(self, count: int) -> None:
        raw = Float64MultiArray(data=[0.0] * count).serialize()
        self.count = count
        self._prefix = raw[: len(raw) - 8 * count]

    def encode(self, values: np.ndarray) -> bytes:
        """The message's bytes with ``values`` (float64, ``count`` of them)."""
        array = np.ascontiguousarray(values, dtype="<f8")
        if array.size != self.count:
            raise ValueError(f"expected {self.count} values, got {array.size}")
        return self._prefix + array.tobytes()


def decode_float64_array(raw: bytes) -> np.ndarray:
    """The values of a ``std_msgs/Float64MultiArray``'s CDR bytes (any layout, which a forward
    controller ignores as well); a :class:`WireError` for bytes that are not one."""
    if raw[:2] != ENCAPSULATION[:2]:
        raise WireError(f"not little-endian CDR (encapsulation {bytes(raw[:4]).hex()})")
    data = memoryview(raw)[4:]
    try:
        (count,) = _UINT32.unpack_from(data, 0)
        offset = 4
        for _ in range(count):  # each dimension: label, size, stride
            _, offset = _string(data, offset)
            offset = ((offset + 3) & ~3) + 8
        values, _ = _doubles(data, offset + 4)  # past data_offset
    except struct.error as error:
        raise WireError(f"a Float64MultiArray cut short: {error}") from error
    return values


def decode_wrench_stamped(raw: bytes) -> tuple[int, np.ndarray]:
    """The stamp (ns) and the 6 values (force, torque) of a ``geometry_msgs/WrenchStamped``'s CDR bytes."""
    if raw[:2] != ENCAPSULATION[:2] or len(raw) < 4 + 8 + 4 + 48:
        raise WireError(f"not a little-endian WrenchStamped ({len(raw)} bytes)")
    sec, nanosec = _STAMP.unpack_from(raw, 4)
    # the wrench's 6 float64 values end the message (its frame id, a string, varies in length)
    return sec * 1_000_000_000 + nanosec, np.frombuffer(
        raw, dtype="<f8", count=6, offset=len(raw) - 48
    ).copy()


BOOL_BYTES = {False: ENCAPSULATION + b"\x00", True: ENCAPSULATION + b"\x01"}
"""A ``std_msgs/Bool``'s bytes."""


__all__ = [
    "BOOL_BYTES",
    "ENCAPSULATION",
    "Float64ArrayEncoder",
    "JointStateEncoder",
    "StampedEncoder",
    "WireError",
    "decode_float64_array",
    "decode_joint_state",
    "decode_wrench_stamped",
]
