"""RTDE framing and field coding: a package is uint16 size (with the 3-byte header), a type
byte, then the payload; every number big-endian."""

from __future__ import annotations

import struct
from collections.abc import Sequence

PROTOCOL_VERSION = 2
V, v, M, U, O, I, S, P = (ord(c) for c in "VvMUOISP")  # noqa: E741 - the protocol's letters

FORMATS: dict[str, str] = {
    "DOUBLE": "d",
    "VECTOR3D": "3d",
    "VECTOR6D": "6d",
    "INT32": "i",
    "UINT32": "I",
    "UINT64": "Q",
    "VECTOR6INT32": "6i",
    "UINT8": "B",
    "BOOL": "?",
}

_VECTOR6D = [
    "target_q",
    "target_qd",
    "target_qdd",
    "target_current",
    "target_moment",
    "actual_q",
    "actual_qd",
    "actual_qdd",
    "actual_current",
    "actual_current_as_torque",
    "actual_moment",
    "joint_control_output",
    "actual_TCP_pose",
    "actual_TCP_speed",
    "actual_TCP_force",
    "target_TCP_pose",
    "target_TCP_speed",
    "joint_temperatures",
    "actual_joint_voltage",
    "ft_raw_wrench",
    "payload_inertia",
]
_DOUBLE = [
    "timestamp",
    "actual_execution_time",
    "speed_scaling",
    "target_speed_fraction",
    "actual_momentum",
    "actual_main_voltage",
    "actual_robot_voltage",
    "actual_robot_current",
    "standard_analog_input0",
    "standard_analog_input1",
    "standard_analog_output0",
    "standard_analog_output1",
    "payload",
]

# What the controller can send, by name (UR's RTDE guide types).
OUTPUTS: dict[str, str] = {
    **dict.fromkeys(_VECTOR6D, "VECTOR6D"),
    **dict.fromkeys(_DOUBLE, "DOUBLE"),
    "actual_tool_accelerometer": "VECTOR3D",
    "payload_cog": "VECTOR3D",
    "robot_mode": "INT32",
    "safety_mode": "INT32",
    "runtime_state": "UINT32",
    "robot_status_bits": "UINT32",
    "safety_status_bits": "UINT32",
    "output_bit_registers0_to_31": "UINT32",
    "output_bit_registers32_to_63": "UINT32",
    "actual_digital_input_bits": "UINT64",
    "actual_digital_output_bits": "UINT64",
    "joint_mode": "VECTOR6INT32",
    **{f"output_int_register_{n}": "INT32" for n in range(48)},
    **{f"output_double_register_{n}": "DOUBLE" for n in range(48)},
}

# What it takes.
INPUTS: dict[str, str] = {
    **{f"input_int_register_{n}": "INT32" for n in range(48)},
    **{f"input_double_register_{n}": "DOUBLE" for n in range(48)},
    "standard_digital_output_mask": "UINT8",
    "standard_digital_output": "UINT8",
    "configurable_digital_output_mask": "UINT8",
    "configurable_digital_output": "UINT8",
    "tool_digital_output_mask": "UINT8",
    "tool_digital_output": "UINT8",
    "speed_slider_mask": "UINT32",
    "speed_slider_fraction": "DOUBLE",
    "standard_analog_output_mask": "UINT8",
    "standard_analog_output_type": "UINT8",
    "standard_analog_output_0": "DOUBLE",
    "standard_analog_output_1": "DOUBLE",
    "external_force_torque": "VECTOR6D",
}


def package(kind: int, payload: bytes = b"") -> bytes:
    return struct.pack(">HB", 3 + len(payload), kind) + payload


def names(payload: bytes) -> list[str]:
    """A recipe's variable names ("a,b,c," with ur-rtde's trailing comma)."""
    return [n for n in payload.decode("ascii", "replace").split(",") if n]


def encode(types: Sequence[str], values: Sequence[object]) -> bytes:
    """Fields in recipe order; None is zero of its type (what the emulator does not model:
    currents, temperatures, voltages…)."""
    parts = []
    for kind, value in zip(types, values, strict=True):
        fmt = ">" + FORMATS[kind]
        count = len(struct.unpack(fmt, bytes(struct.calcsize(fmt))))
        if value is None:
            value = (0,) * count if count > 1 else 0
        parts.append(struct.pack(fmt, *value) if count > 1 else struct.pack(fmt, value))  # type: ignore[misc]
    return b"".join(parts)


def decode(types: Sequence[str], data: bytes) -> list[object]:
    """The fields present, in order; a package shorter than its recipe (ur-rtde sends some
    so) gives the fields that fit."""
    found: list[object] = []
    offset = 0
    for kind in types:
        fmt = ">" + FORMATS[kind]
        size = struct.calcsize(fmt)
        if offset + size > len(data):
            break
        values = struct.unpack_from(fmt, data, offset)
        found.append(values if len(values) > 1 else values[0])
        offset += size
    return found
