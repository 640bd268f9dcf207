"""Where reports come from: the USB device through hidapi, spacenavd's socket when that
daemon owns the device, or a recording played back (the same parser either way)."""

from __future__ import annotations

import json
import socket
import struct
import time
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any

from openpendant.device_drivers.spacemouse.devices import MODELS, SpaceMouseModel, find_model
from openpendant.device_drivers.spacemouse.reports import RawInput, ReportError, parse_report


class DeviceGone(Exception):
    """The device was unplugged, or its daemon went away."""


class ReportSource(ABC):
    model: SpaceMouseModel | None = None
    description = ""

    @abstractmethod
    def open(self) -> None: ...

    @abstractmethod
    def read(self, timeout: float) -> RawInput | None:
        """The next input, or None when nothing came within `timeout`."""

    def close(self) -> None:
        return None


class HidSource(ReportSource):
    """The first known 3Dconnexion device on the USB bus (or the one given by ids)."""

    def __init__(self, vendor_id: int | None = None, product_id: int | None = None) -> None:
        self.wanted = (vendor_id, product_id)
        self.device: Any = None
        self.serial = ""

    def open(self) -> None:
        import hid  # hidapi; imported here so the other sources work without a HID stack

        for entry in hid.enumerate():
            ids = (entry["vendor_id"], entry["product_id"])
            model = find_model(*ids)
            if model is None or (self.wanted != (None, None) and ids != self.wanted):
                continue
            # The multi-axis controller collection, not a keyboard or consumer one.
            if entry.get("usage_page", 1) not in (0, 1):
                continue
            device = hid.device()
            device.open_path(entry["path"])
            self.device, self.model = device, model
            self.serial = str(entry.get("serial_number") or "")
            self.description = f"{model.name} (USB {ids[0]:04x}:{ids[1]:04x})"
            return
        known = ", ".join(m.name for m in MODELS)
        raise DeviceGone(f"no SpaceMouse connected (supported: {known})")

    def read(self, timeout: float) -> RawInput | None:
        try:
            data = self.device.read(64, max(1, int(timeout * 1000)))
        except (OSError, ValueError) as exc:
            raise DeviceGone(f"the device stopped answering: {exc}") from exc
        if not data:
            return None
        try:
            return parse_report(bytes(data))
        except ReportError:
            return None

    def close(self) -> None:
        if self.device is not None:
            self.device.close()
            self.device = None


SPNAV_MOTION, SPNAV_PRESS, SPNAV_RELEASE = 0, 1, 2


class SpacenavdSource(ReportSource):
    """spacenavd's client protocol: 32-byte events of eight int32 (type, then six axes and
    the period for motion, or the button number for presses and releases)."""

    def __init__(self, path: str = "/var/run/spnav.sock") -> None:
        self.path = path
        self.sock: socket.socket | None = None
        self.pressed: set[int] = set()
        self.buffer = b""

    def open(self) -> None:
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            sock.connect(self.path)
        except OSError as exc:
            sock.close()
            raise DeviceGone(f"spacenavd is not running ({self.path}): {exc}") from exc
        self.sock = sock
        self.description = f"spacenavd at {self.path}"

    def read(self, timeout: float) -> RawInput | None:
        assert self.sock is not None
        while len(self.buffer) < 32:
            self.sock.settimeout(timeout)
            try:
                chunk = self.sock.recv(4096)
            except TimeoutError:
                return None
            except OSError as exc:
                raise DeviceGone(f"lost spacenavd: {exc}") from exc
            if not chunk:
                raise DeviceGone("spacenavd closed the connection")
            self.buffer += chunk
        event, self.buffer = self.buffer[:32], self.buffer[32:]
        kind, *values = struct.unpack("=8i", event)
        if kind == SPNAV_MOTION:
            return RawInput(
                translation=(values[0], values[1], values[2]),
                rotation=(values[3], values[4], values[5]),
            )
        if kind in (SPNAV_PRESS, SPNAV_RELEASE):
            (self.pressed.add if kind == SPNAV_PRESS else self.pressed.discard)(values[0])
            return RawInput(buttons=frozenset(self.pressed))
        return None

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None


class ReplaySource(ReportSource):
    """A recording, one JSON object per line: {"t": seconds, "report": "hex bytes"}, or
    {"t": seconds, "event": "unplug"}. After the last line the device stays silent, as a
    stuck one would, unless the recording ends by unplugging it."""

    def __init__(
        self, path: Path, model: SpaceMouseModel | None = None, wait_for_start: bool = False
    ) -> None:
        self.path = path
        self.model = model or MODELS[0]
        self.lines: list[dict[str, Any]] = []
        self.index = 0
        self.wait_for_start = wait_for_start
        self.started: float | None = None

    def open(self) -> None:
        self.lines = [
            json.loads(line) for line in self.path.read_text().splitlines() if line.strip()
        ]
        self.index = 0
        self.started = None if self.wait_for_start else time.monotonic()
        self.description = f"replay of {self.path.name}"

    def restart(self) -> None:
        """Play the recording from its beginning, now."""
        self.index = 0
        self.started = time.monotonic()

    def read(self, timeout: float) -> RawInput | None:
        if self.started is None or self.index >= len(self.lines):
            time.sleep(timeout)
            return None
        line = self.lines[self.index]
        wait = self.started + float(line["t"]) - time.monotonic()
        if wait > timeout:
            time.sleep(timeout)
            return None
        time.sleep(max(0.0, wait))
        self.index += 1
        if line.get("event") == "unplug":
            raise DeviceGone("unplugged")
        return parse_report(bytes.fromhex(line["report"]))
