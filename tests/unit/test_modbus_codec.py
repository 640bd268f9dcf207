"""Register coding of the Modbus I/O driver: each data type in each byte and word order,
scaling, values a type cannot hold, and register maps that cannot be right."""

from __future__ import annotations

import itertools

import pytest
from pydantic import ValidationError

from openpendant.device_drivers.modbus_io.codec import decode, encode, to_raw, to_unit
from openpendant.device_drivers.modbus_io.registers import RegisterMap

ORDERS = list(itertools.product(("big", "little"), repeat=2))


def test_known_words_in_each_order() -> None:
    # 1.0 as float32 is 0x3F800000; -2 as int32 is 0xFFFFFFFE.
    assert encode(1.0, "float32", "big", "big") == [0x3F80, 0x0000]
    assert encode(1.0, "float32", "big", "little") == [0x0000, 0x3F80]
    assert encode(1.0, "float32", "little", "big") == [0x803F, 0x0000]
    assert encode(1.0, "float32", "little", "little") == [0x0000, 0x803F]
    assert encode(-2, "int32", "big", "big") == [0xFFFF, 0xFFFE]
    assert encode(-2, "int16", "big", "big") == [0xFFFE]
    assert encode(0x1234, "uint16", "little", "big") == [0x3412]
    assert encode(0x12345678, "uint32", "big", "little") == [0x5678, 0x1234]


@pytest.mark.parametrize(("byte_order", "word_order"), ORDERS)
def test_every_type_round_trips_in_every_order(byte_order: str, word_order: str) -> None:
    cases: dict[str, list[float]] = {
        "int16": [-32768, -1, 0, 1234, 32767],
        "uint16": [0, 1, 40000, 65535],
        "int32": [-(2**31), -70000, 0, 70000, 2**31 - 1],
        "uint32": [0, 70000, 2**32 - 1],
        "float32": [0.0, -1.5, 3.25, 1e-20, 3.0e38],
    }
    for data_type, values in cases.items():
        for value in values:
            words = encode(value, data_type, byte_order, word_order)  # type: ignore[arg-type]
            assert all(0 <= w <= 0xFFFF for w in words)
            back = decode(words, data_type, byte_order, word_order)  # type: ignore[arg-type]
            assert back == pytest.approx(value, rel=1e-6), (data_type, value)


def test_values_a_type_cannot_hold_are_refused_not_wrapped() -> None:
    for value, data_type in (
        (32768, "int16"),
        (-1, "uint16"),
        (65536, "uint16"),
        (2**31, "int32"),
        (-1, "uint32"),
        (1.5, "int16"),
        (float("nan"), "float32"),
        (float("inf"), "int32"),
        (1e39, "float32"),
    ):
        with pytest.raises(ValueError, match=r"finite|fit|whole|beyond"):
            encode(value, data_type, "big", "big")  # type: ignore[arg-type]


def test_scaling_to_the_signals_unit_and_back() -> None:
    # A 4-20 mA input on 0..27648 counts (a common analog card), shown in bar 0..10.
    scale, offset = 10 / 27648, 0.0
    assert to_unit(13824, scale, offset) == pytest.approx(5.0)
    assert to_raw(5.0, scale, offset, "int16") == 13824
    assert to_raw(2.5, 0.1, 0.0, "uint16") == 25
    assert to_raw(2.5, 0.1, 0.0, "float32") == pytest.approx(25.0)
    assert to_unit(25, 0.1, -273.15) == pytest.approx(-270.65)


def test_a_map_that_cannot_be_right_is_refused_with_the_reason() -> None:
    def bad(signals: list[dict[str, object]], says: str) -> None:
        with pytest.raises(ValidationError) as refused:
            RegisterMap.model_validate({"signals": signals})
        assert says in str(refused.value)

    bad([{"name": "a", "table": "coil", "address": 0, "type": "int16"}], "holds a bool")
    bad([{"name": "a", "table": "holding_register", "address": 0, "type": "bool"}], "number")
    bad(
        [
            {"name": "a", "table": "coil", "address": 0},
            {"name": "a", "table": "coil", "address": 1},
        ],
        "named twice",
    )
    bad(
        [
            {"name": "a", "table": "holding_register", "address": 10, "type": "float32"},
            {"name": "b", "table": "holding_register", "address": 11},
        ],
        "share holding_register 11",
    )
    bad([{"name": "a", "table": "input_register", "address": 65535, "type": "int32"}], "65535")
    bad([{"name": "a", "table": "input_register", "address": 0, "scale": 0}], "scale 0")
    bad([{"name": "Bad Name", "table": "coil", "address": 0}], "pattern")


def test_signals_are_read_in_few_requests_within_the_protocols_limits() -> None:
    signals = [{"name": f"in{i}", "table": "discrete_input", "address": i} for i in range(40)]
    signals += [
        {"name": "far", "table": "discrete_input", "address": 5000},
        {"name": "t1", "table": "input_register", "address": 0, "type": "float32"},
        {"name": "t2", "table": "input_register", "address": 10},
    ]
    signals += [
        {"name": f"r{i}", "table": "holding_register", "address": 2 * i, "type": "int32"}
        for i in range(100)
    ]
    blocks = RegisterMap.model_validate({"signals": signals}).blocks()
    assert ("discrete_input", 0, 40) in blocks and ("discrete_input", 5000, 1) in blocks
    assert ("input_register", 0, 11) in blocks
    held = [b for b in blocks if b[0] == "holding_register"]
    assert sum(count for _, _, count in held) == 200 and all(c <= 125 for _, _, c in held)
