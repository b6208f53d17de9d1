"""ROS 2 messages as plain typed records with ROS 2's wire names (Cyclone DDS's IDL classes).

Each class serialises to the CDR bytes a ROS 2 node sends (XCDR1, little endian, as
``rmw_cyclonedds`` writes them; a test holds them equal to ``rosbags``' serialiser) and carries the
DDS type name ``<pkg>::msg::dds_::<Type>_`` under which ROS 2 announces it. :data:`ROS_TYPES` maps
ROS 2's names (``sensor_msgs/msg/JointState``) to the classes, for the bag and the tests.
"""

# No ``from __future__ import annotations``: Cyclone reads the fields' types as objects.
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import cyclonedds.idl.annotations as annotate
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint8, uint32

if TYPE_CHECKING:  # what a type checker sees of the wire types: Python's own
    Strings = Sequence[str]
    Floats = Sequence[float]
else:
    Strings = sequence[str]
    Floats = sequence[float64]


@dataclass
@annotate.final
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    """``builtin_interfaces/msg/Time``: seconds and nanoseconds."""

    sec: int32 = 0
    nanosec: uint32 = 0

    @classmethod
    def of(cls, seconds: float) -> "Time":
        """The stamp of ``seconds`` (s since the epoch or the start of a simulation)."""
        nanoseconds = round(seconds * 1e9)
        return cls(int(nanoseconds // 1_000_000_000), int(nanoseconds % 1_000_000_000))

    @property
    def seconds(self) -> float:
        """The stamp in seconds."""
        return self.sec + 1e-9 * self.nanosec


@dataclass
@annotate.final
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    """``std_msgs/msg/Header``: a stamp and a frame."""

    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
@annotate.final
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    """``sensor_msgs/msg/JointState``: joints by name, positions (rad), velocities (rad/s), efforts
    (N·m); velocity or effort may be empty."""

    header: Header = field(default_factory=Header)
    name: Strings = field(default_factory=list)
    position: Floats = field(default_factory=list)
    velocity: Floats = field(default_factory=list)
    effort: Floats = field(default_factory=list)


@dataclass
@annotate.final
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    """``geometry_msgs/msg/Vector3``."""

    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
@annotate.final
class Wrench(IdlStruct, typename="geometry_msgs::msg::dds_::Wrench_"):
    """``geometry_msgs/msg/Wrench``: force (N) and torque (N·m)."""

    force: Vector3 = field(default_factory=Vector3)
    torque: Vector3 = field(default_factory=Vector3)


@dataclass
@annotate.final
class WrenchStamped(IdlStruct, typename="geometry_msgs::msg::dds_::WrenchStamped_"):
    """``geometry_msgs/msg/WrenchStamped``."""

    header: Header = field(default_factory=Header)
    wrench: Wrench = field(default_factory=Wrench)


@dataclass
@annotate.final
class Bool(IdlStruct, typename="std_msgs::msg::dds_::Bool_"):
    """``std_msgs/msg/Bool``."""

    data: bool = False


@dataclass
@annotate.final
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    """``std_msgs/msg/MultiArrayDimension``."""

    label: str = ""
    size: uint32 = 0
    stride: uint32 = 0


if TYPE_CHECKING:
    Dimensions = Sequence[MultiArrayDimension]
else:
    Dimensions = sequence[MultiArrayDimension]


@dataclass
@annotate.final
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    """``std_msgs/msg/MultiArrayLayout``."""

    dim: Dimensions = field(default_factory=list)
    data_offset: uint32 = 0


@dataclass
@annotate.final
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    """``std_msgs/msg/Float64MultiArray``: what a ``ros2_control`` forward controller takes."""

    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: Floats = field(default_factory=list)


@dataclass
@annotate.final
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    """``diagnostic_msgs/msg/KeyValue``."""

    key: str = ""
    value: str = ""


if TYPE_CHECKING:
    KeyValues = Sequence[KeyValue]
else:
    KeyValues = sequence[KeyValue]


@dataclass
@annotate.final
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    """``diagnostic_msgs/msg/DiagnosticStatus``: level OK 0, WARN 1, ERROR 2, STALE 3."""

    level: uint8 = 0
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: KeyValues = field(default_factory=list)


if TYPE_CHECKING:
    Statuses = Sequence[DiagnosticStatus]
else:
    Statuses = sequence[DiagnosticStatus]


@dataclass
@annotate.final
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    """``diagnostic_msgs/msg/DiagnosticArray``."""

    header: Header = field(default_factory=Header)
    status: Statuses = field(default_factory=list)


DIAGNOSTIC_LEVELS = {"ok": 0, "warn": 1, "error": 2, "stale": 3}
"""``DiagnosticStatus.level`` by name."""

ROS_TYPES: dict[str, type[IdlStruct]] = {
    "builtin_interfaces/msg/Time": Time,
    "std_msgs/msg/Header": Header,
    "sensor_msgs/msg/JointState": JointState,
    "geometry_msgs/msg/Vector3": Vector3,
    "geometry_msgs/msg/Wrench": Wrench,
    "geometry_msgs/msg/WrenchStamped": WrenchStamped,
    "std_msgs/msg/Bool": Bool,
    "std_msgs/msg/MultiArrayDimension": MultiArrayDimension,
    "std_msgs/msg/MultiArrayLayout": MultiArrayLayout,
    "std_msgs/msg/Float64MultiArray": Float64MultiArray,
    "diagnostic_msgs/msg/KeyValue": KeyValue,
    "diagnostic_msgs/msg/DiagnosticStatus": DiagnosticStatus,
    "diagnostic_msgs/msg/DiagnosticArray": DiagnosticArray,
}
"""The message classes by ROS 2 type name."""


def ros_type_name(message: type[IdlStruct]) -> str:
    """ROS 2's name of a message class (``sensor_msgs/msg/JointState``)."""
    for name, cls in ROS_TYPES.items():
        if cls is message:
            return name
    raise KeyError(f"{message.__name__} is not a ROS 2 message of lwrlab.live.messages")
