"""SpaceMouse reports through the real parser, the axis settings, and the sources that feed
the driver (spacenavd's socket protocol, recordings)."""

from __future__ import annotations

import json
import socket
import struct
import threading
from pathlib import Path

import numpy as np
import pytest

from openpendant.device_drivers.spacemouse.devices import MODELS, find_model
from openpendant.device_drivers.spacemouse.driver import SpaceMouseDriver
from openpendant.device_drivers.spacemouse.reports import (
    AxisFilter,
    AxisSettings,
    RawInput,
    ReportError,
    parse_report,
)
from openpendant.device_drivers.spacemouse.sources import DeviceGone, ReplaySource, SpacenavdSource
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.input import InputInfo


def separate(translation: tuple[int, int, int], rotation: tuple[int, int, int]) -> list[bytes]:
    return [b"\x01" + struct.pack("<3h", *translation), b"\x02" + struct.pack("<3h", *rotation)]


def combined(translation: tuple[int, int, int], rotation: tuple[int, int, int]) -> bytes:
    return b"\x01" + struct.pack("<6h", *translation, *rotation)


def buttons(*pressed: int, width: int = 2) -> bytes:
    mask = sum(1 << b for b in pressed)
    return b"\x03" + mask.to_bytes(width, "little")


def test_reports_captured_from_a_space_navigator() -> None:
    assert parse_report(bytes.fromhex("01000000000000")) == RawInput(translation=(0, 0, 0))
    assert parse_report(bytes.fromhex("020000e2ff0000")) == RawInput(rotation=(0, -30, 0))
    assert parse_report(bytes.fromhex("030100")) == RawInput(buttons=frozenset({0}))
    assert parse_report(bytes.fromhex("030300")) == RawInput(buttons=frozenset({0, 1}))
    assert parse_report(bytes.fromhex("030000")) == RawInput(buttons=frozenset())


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
def test_every_supported_model_parses_in_its_layout(model: object) -> None:
    from openpendant.device_drivers.spacemouse.devices import SpaceMouseModel

    assert isinstance(model, SpaceMouseModel)
    assert find_model(model.vendor_id, model.product_id) is model
    translation, rotation = (120, -350, 7), (-1, 0, 349)
    if model.layout == "separate":
        parsed = [parse_report(r) for r in separate(translation, rotation)]
        assert parsed == [RawInput(translation=translation), RawInput(rotation=rotation)]
    else:
        assert parse_report(combined(translation, rotation)) == RawInput(
            translation=translation, rotation=rotation
        )
    top = model.buttons - 1
    width = (model.buttons + 7) // 8
    assert parse_report(buttons(0, top, width=width)) == RawInput(buttons=frozenset({0, top}))


def test_reports_that_carry_no_input_are_ignored_and_broken_ones_refused() -> None:
    assert parse_report(bytes.fromhex("1764")) is None  # battery level (wireless models)
    with pytest.raises(ReportError):
        parse_report(b"\x01\x00\x00")
    with pytest.raises(ReportError):
        parse_report(b"")


def test_axis_filter_dead_zone_direction_gain_and_mapping() -> None:
    plain = AxisFilter(AxisSettings(dead_zone=0.0, invert=[]))
    assert plain.apply(np.array([350, -175, 0, 700, 0, -350])) == [1.0, -0.5, 0.0, 1.0, 0.0, -1.0]
    default = AxisFilter(AxisSettings())  # y, z, ry, rz inverted; 5 % dead zone
    out = default.apply(np.array([10, 350, 350, 0, 100, 0]))
    assert out[0] == 0.0  # inside the dead zone
    assert out[1] == -1.0  # pulled toward the operator: -y
    assert out[2] == -1.0  # pushed down: -z
    assert out[4] == pytest.approx(-(100 / 350 - 0.05) / 0.95)
    swapped = AxisFilter(
        AxisSettings(
            dead_zone=0.0, invert=[], source_axis=[1, 0, 2, 3, 4, 5], sensitivity=[2, 1, 1, 1, 1, 1]
        )
    )
    assert swapped.apply(np.array([0, 100, 0, 0, 0, 0]))[0] == pytest.approx(200 / 350)


@pytest.mark.parametrize(
    "bad",
    [
        {"sensitivity": [1, 1, 1]},
        {"source_axis": [0, 0, 1, 2, 3, 4]},
        {"invert": ["w"]},
        {"dead_zone": 1.5},
    ],
)
def test_bad_axis_settings_are_refused(bad: dict[str, object]) -> None:
    with pytest.raises(ValueError):  # noqa: PT011 - pydantic's ValidationError
        AxisSettings(**bad)


def test_spacenavd_protocol(tmp_path: Path) -> None:
    path = str(tmp_path / "spnav.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(path)
    server.listen(1)

    def daemon() -> None:
        conn, _ = server.accept()
        conn.sendall(struct.pack("=8i", 0, 10, -20, 30, -1, 2, -3, 16))  # motion
        conn.sendall(struct.pack("=8i", 1, 1, 0, 0, 0, 0, 0, 0)[:20])  # a press, in two parts
        conn.sendall(struct.pack("=8i", 1, 1, 0, 0, 0, 0, 0, 0)[20:])
        conn.sendall(struct.pack("=8i", 2, 1, 0, 0, 0, 0, 0, 0))  # its release
        conn.close()

    thread = threading.Thread(target=daemon)
    thread.start()
    source = SpacenavdSource(path)
    source.open()
    assert source.read(2) == RawInput(translation=(10, -20, 30), rotation=(-1, 2, -3))
    assert source.read(2) == RawInput(buttons=frozenset({1}))
    assert source.read(2) == RawInput(buttons=frozenset())
    with pytest.raises(DeviceGone):
        source.read(2)
    thread.join()
    server.close()


def test_spacenavd_not_running(tmp_path: Path) -> None:
    with pytest.raises(DeviceGone, match="spacenavd is not running"):
        SpacenavdSource(str(tmp_path / "none.sock")).open()


def test_replay_feeds_the_driver_and_an_unplug_disconnects_it(tmp_path: Path) -> None:
    recording = tmp_path / "push.jsonl"
    lines = [{"t": 0.0, "report": r.hex()} for r in separate((175, 0, 0), (0, 0, 0))]
    lines += [{"t": 0.05, "report": buttons(1).hex()}, {"t": 0.1, "event": "unplug"}]
    recording.write_text("\n".join(json.dumps(line) for line in lines))
    source = ReplaySource(recording)
    identity = DeviceIdentity(uuid="m1", kind="input", model="spacemouse", name="m")
    driver = SpaceMouseDriver(
        identity, InputInfo(model="x"), source, AxisSettings(dead_zone=0.0), reopen=False
    )
    source.open()
    for _ in range(3):
        raw = source.read(1.0)
        assert raw is not None
        driver.apply(raw)
    state = driver.state()
    assert state.axes[0] == pytest.approx(0.5)
    assert state.buttons == [1]
    assert state.connected
    with pytest.raises(DeviceGone):
        source.read(1.0)
