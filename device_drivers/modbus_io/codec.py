"""Register values as numbers and back: 16- and 32-bit integers and 32-bit floats, in the
byte and word order the device uses, with linear scaling to the signal's unit.

On the wire each register is one 16-bit word, its high byte first. A device with "little"
byte order swaps the two bytes of each word; one with "little" word order sends the low
word of a 32-bit value first (both are common: Schneider, Wago and many gateways differ)."""

from __future__ import annotations

import math
import struct
from typing import Literal

DataType = Literal["bool", "int16", "uint16", "int32", "uint32", "float32"]
Order = Literal["big", "little"]

_FORMAT = {"int16": ">h", "uint16": ">H", "int32": ">i", "uint32": ">I", "float32": ">f"}


def word_count(data_type: DataType) -> int:
    return 2 if data_type in ("int32", "uint32", "float32") else 1


def _to_bytes(words: list[int], byte_order: Order, word_order: Order) -> bytes:
    ordered = list(reversed(words)) if word_order == "little" else list(words)
    out = bytearray()
    for word in ordered:
        pair = word.to_bytes(2, "big")
        out += pair[::-1] if byte_order == "little" else pair
    return bytes(out)


def _to_words(raw: bytes, byte_order: Order, word_order: Order) -> list[int]:
    words = []
    for i in range(0, len(raw), 2):
        pair = raw[i : i + 2]
        words.append(int.from_bytes(pair[::-1] if byte_order == "little" else pair, "big"))
    return list(reversed(words)) if word_order == "little" else words


def decode(words: list[int], data_type: DataType, byte_order: Order, word_order: Order) -> float:
    """The raw number `words` (in wire order) hold."""
    if len(words) != word_count(data_type):
        raise ValueError(f"{data_type} takes {word_count(data_type)} registers, got {len(words)}")
    (value,) = struct.unpack(_FORMAT[data_type], _to_bytes(words, byte_order, word_order))
    return float(value)


def encode(value: float, data_type: DataType, byte_order: Order, word_order: Order) -> list[int]:
    """The registers (in wire order) that hold the raw number `value`; a value the type
    cannot hold is a ValueError, never wrapped or clipped."""
    if not math.isfinite(value):
        raise ValueError("not a finite number")
    if data_type == "float32":
        try:
            packed = struct.pack(">f", value)
        except OverflowError as exc:
            raise ValueError(f"{value:g} is beyond a float32") from exc
    else:
        if value != int(value):
            raise ValueError(f"{value} is not a whole number, as {data_type} needs")
        try:
            packed = struct.pack(_FORMAT[data_type], int(value))
        except struct.error as exc:
            raise ValueError(f"{value:g} does not fit in {data_type}") from exc
    return _to_words(packed, byte_order, word_order)


def to_unit(raw: float, scale: float, offset: float) -> float:
    return raw * scale + offset


def to_raw(value: float, scale: float, offset: float, data_type: DataType) -> float:
    """The raw number for a value in the signal's unit (rounded for integer types)."""
    raw = (value - offset) / scale
    return raw if data_type == "float32" else float(round(raw))
