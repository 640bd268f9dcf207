"""Any Robot Raconteur standard tool (`com.robotraconteur.robotics.tool.Tool`: electric,
pneumatic and vacuum grippers) as an OpenPendant gripper. A reader thread follows the tool's
`tool_state` wire; a motion is RR's `open`, `close` or (for tools with continuous commands)
`setf_command`, followed until the tool stops actuating. A tool whose state stops coming (its
`seqno` standing still for `STALE_AFTER`) or whose wire fails is a fault, said in the state,
until it is back (and activated again): the reader connects again every `reconnect`
seconds.

Positions are the tool's own (`open_position`, `close_position`, in metres for grippers
that say so) turned into metres of opening from closed."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from openpendant.plugins.robotraconteur.node import Node
from openpendant.plugins.robotraconteur.robot_link import LINK_ERRORS
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.gripper import (
    GripperDriver,
    GripperInfo,
    GripperMotion,
    GripperState,
)
from openpendant.runtime.kit.errors import DeviceError, InvalidValue, OpenPendantError, Unavailable

log = logging.getLogger(__name__)
NAMESPACE = "com.robotraconteur.robotics.tool"
STALE_AFTER = 1.0  # s without a new state: the tool is not answering
PERIOD = 0.02  # s between two looks at the wire
ENABLED_WITHIN = 3.0  # s for the tool to say it is ready once enabled
CAPABILITIES = {"continuous_command": 0x2, "software_reset_errors": 0x8, "software_enable": 0x10}


class ToolFault(OpenPendantError):
    status = 409
    code = "gripper_fault"


@dataclass(frozen=True)
class ToolRange:
    """Where the tool's positions and commands are when open and when closed."""

    open_position: float
    close_position: float
    command_open: float
    command_close: float
    actuation_time: float  # s for the whole stroke
    capabilities: int

    @property
    def stroke(self) -> float:
        return abs(self.open_position - self.close_position)

    def opening(self, position: float) -> float:
        """The tool's position as metres of opening."""
        return min(max(abs(position - self.close_position), 0.0), self.stroke)

    def command(self, opening: float) -> float:
        """The command that opens it `opening` metres."""
        share = opening / self.stroke
        return self.command_close + share * (self.command_open - self.command_close)

    def can(self, capability: str) -> bool:
        return bool(self.capabilities & CAPABILITIES[capability])


def tool_range_of(tool_info: Any) -> ToolRange:
    def value(name: str, default: float) -> float:
        found = getattr(tool_info, name, None)
        return default if found is None else float(found)

    opened, closed = value("open_position", 1.0), value("close_position", 0.0)
    if opened == closed:
        opened, closed = 1.0, 0.0  # a tool that does not say: open is 1, closed 0
    return ToolRange(
        open_position=opened,
        close_position=closed,
        command_open=value("command_open", opened),
        command_close=value("command_close", closed),
        actuation_time=max(value("actuation_time", 1.0), 0.01),
        capabilities=int(getattr(tool_info, "tool_capabilities", 0) or 0),
    )


@dataclass(frozen=True)
class ToolReading:
    seqno: int
    received: float  # monotonic, when first seen
    flags: int
    position: float


class RRTool(GripperDriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        info: GripperInfo,
        tool_range: ToolRange,
        url: str,
        *,
        node: Node,
        client: Any,
        reconnect: float = 1.0,
    ) -> None:
        super().__init__(identity, info)
        self.range, self.url, self.node, self.reconnect = tool_range, url, node, reconnect
        self.flag_bits: dict[str, int] = dict(node.constants(NAMESPACE, client)["ToolStateFlags"])
        self._lock = threading.Lock()
        self._client: Any = client
        self._wire: Any = None
        self._reading: ToolReading | None = None
        self._error = ""  # why the tool cannot be reached; empty while it can
        self._connected_at = time.monotonic()
        self._seqno = 0
        self._running = threading.Event()
        self._thread: threading.Thread | None = None

    # The reader thread --------------------------------------------------------------------

    async def start(self) -> None:
        self._running.set()
        self._thread = threading.Thread(target=self._read_forever, name="rr-tool", daemon=True)
        self._thread.start()

    async def shutdown(self) -> None:
        self._running.clear()
        if self._thread is not None:
            await asyncio.to_thread(self._thread.join, 3.0)
        self._drop()
        self.node.close()

    def _read_forever(self) -> None:
        last_attempt = time.monotonic()
        while self._running.is_set():
            if self._client is None:
                if time.monotonic() - last_attempt >= self.reconnect:
                    last_attempt = time.monotonic()
                    self._connect()
            else:
                try:
                    self._read()
                except Exception as exc:
                    self._lost(f"the tool at {self.url} stopped answering: {exc}")
            time.sleep(PERIOD)

    def _connect(self) -> None:
        try:
            client = self.node.connect(self.url)
        except Exception as exc:
            with self._lock:
                self._error = f"cannot reach the tool at {self.url}: {exc}"
            return
        with self._lock:
            self._client, self._wire, self._reading = client, None, None
        log.info("connected to %s", self.url)

    def _read(self) -> None:
        if self._wire is None:
            self._wire = self._client.tool_state.Connect()
            self._connected_at = time.monotonic()
        ok, value, _ = self._wire.TryGetInValue()
        now = time.monotonic()
        with self._lock:
            last = self._reading
            if ok and (last is None or int(value.seqno) != last.seqno):
                self._reading = ToolReading(
                    int(value.seqno), now, int(value.tool_state_flags), float(value.position)
                )
                self._error = ""
                self._seqno += 1
                return
            since = last.received if last is not None else self._connected_at
        if now - since > STALE_AFTER:
            # Its connection may look open for a while yet: dropped, and made again.
            self._lost(f"the tool at {self.url} sent no new state for {STALE_AFTER:g} s")

    def _lost(self, why: str) -> None:
        log.warning("%s", why)
        self._drop()
        with self._lock:
            self._error, self._reading = why, None
            self._seqno += 1

    def _drop(self) -> None:
        with self._lock:
            client, wire, self._client, self._wire = self._client, self._wire, None, None
        if wire is not None:
            with contextlib.suppress(Exception):
                wire.Close()
        if client is not None:
            with contextlib.suppress(Exception):
                self.node.node.DisconnectService(client)

    # Reading the state ----------------------------------------------------------------------

    def _has(self, reading: ToolReading, flag: str) -> bool:
        bit = self.flag_bits.get(flag, 0)
        return bit != 0 and reading.flags & bit == bit

    def _fault_of(self, reading: ToolReading) -> str:
        for flag, said in (
            ("estop", "the tool's E-stop"),
            ("fatal_error", "the tool reports a fatal error: restart it"),
            ("communication_failure", "the tool lost its own controller"),
            ("error", "the tool reports an error: activate it again"),
        ):
            if self._has(reading, flag):
                return said
        return ""

    def state(self) -> GripperState:
        with self._lock:
            reading, error, seqno = self._reading, self._error, self._seqno
        if reading is None or error:
            return GripperState(
                seqno=seqno,
                ts=time.time(),
                connected=False,
                activated=False,
                fault=error or "not connected yet",
            )
        return GripperState(
            seqno=seqno,
            ts=time.time(),
            connected=True,
            activated=self._has(reading, "ready"),
            position=self.range.opening(reading.position),
            moving=self._has(reading, "actuating"),
            object_detected=self._has(reading, "gripping"),
            fault=self._fault_of(reading),
        )

    # Commands -------------------------------------------------------------------------------

    async def _call(self, what: str, call: Callable[[Any], None]) -> None:
        """An RR call (they block), refused with the tool's words."""
        with self._lock:
            client, error = self._client, self._error
        if client is None or error:
            raise DeviceError(error or f"not connected to the tool at {self.url}")
        try:
            await asyncio.to_thread(call, client)
        except LINK_ERRORS as exc:
            raise DeviceError(f"the tool at {self.url} did not answer {what}: {exc}") from exc
        except Exception as exc:
            raise ToolFault(f"the tool refused {what}: {exc}") from exc

    async def _until(self, done: Callable[[ToolReading], bool], timeout: float, what: str) -> None:
        """Until `done` holds, or the tool faults, in its states sent after now: from the
        second new one on (one composed before a call returned may arrive after it)."""
        deadline = time.monotonic() + timeout
        with self._lock:
            after = (self._reading.seqno if self._reading is not None else -1) + 1
        while True:
            with self._lock:
                reading, error = self._reading, self._error
            if error:
                raise DeviceError(f"{what}: {error}")
            if reading is not None and reading.seqno > after:
                fault = self._fault_of(reading)
                if fault:
                    raise ToolFault(f"{what}: {fault}")
                if done(reading):
                    return
            if time.monotonic() > deadline:
                raise Unavailable(
                    f"{what} did not finish in {timeout:.1f} s", code="gripper_timeout"
                )
            await asyncio.sleep(PERIOD)

    async def activate(self) -> GripperState:
        if self.range.can("software_reset_errors"):
            await self._call("reset errors", lambda c: c.reset_errors())
        if self.range.can("software_enable"):
            await self._call("enable", lambda c: c.enable())
        await self._until(lambda r: self._has(r, "ready"), ENABLED_WITHIN, "the activation")
        return self.state()

    async def _go(
        self, what: str, call: Callable[[Any], None], at_goal: Callable[[ToolReading], bool]
    ) -> GripperState:
        """Done once the tool, seen actuating or at its goal, has stopped (there, or on an
        object), within its actuation time and a margin."""
        state = self.state()
        if not state.connected:
            raise DeviceError(state.fault)
        if not state.activated:
            raise InvalidValue(
                "activate the gripper first (Activate in the Jog panel, or the activate block)",
                code="not_activated",
            )
        moved = [False]

        def stopped(reading: ToolReading) -> bool:
            if self._has(reading, "actuating"):
                moved[0] = True
                return False
            return moved[0] or at_goal(reading)

        await self._call(what, call)
        await self._until(stopped, self.range.actuation_time + 2.0, f"the {what}")
        return self.state()

    def _at(self, opening: float) -> Callable[[ToolReading], bool]:
        return lambda r: abs(self.range.opening(r.position) - opening) < 1e-3

    async def open(self, motion: GripperMotion) -> GripperState:
        opened = self._at(self.range.stroke)
        return await self._go(
            "open", lambda c: c.open(), lambda r: self._has(r, "opened") or opened(r)
        )

    async def close(self, motion: GripperMotion) -> GripperState:
        def closed(r: ToolReading) -> bool:
            return any(self._has(r, f) for f in ("closed", "gripping", "missed"))

        return await self._go("close", lambda c: c.close(), closed)

    async def move(self, motion: GripperMotion) -> GripperState:
        if not self.range.can("continuous_command"):
            raise InvalidValue(f"the {self.info.model} only opens and closes")
        if motion.position is None:
            raise InvalidValue("a move needs the position (m of opening)")
        if motion.position > self.range.stroke:
            raise InvalidValue(f"the {self.info.model} opens at most {self.range.stroke:g} m")
        command, there = self.range.command(motion.position), self._at(motion.position)

        def arrived(r: ToolReading) -> bool:
            return there(r) or self._has(r, "gripping")

        return await self._go("move", lambda c: c.setf_command(command), arrived)

    async def stop(self) -> GripperState:
        await self._call("halt", lambda c: c.halt())
        return self.state()
