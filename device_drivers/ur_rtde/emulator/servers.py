"""The controller's network interfaces on one address: RTDE on 30004, the dashboard server
on 29999 and the script port 30003 (where ur-rtde uploads its control script). Each
emulator takes its own loopback address (127.0.0.2, 127.0.0.3, …) since ur-rtde's ports are
fixed."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import re
import socket
import struct
import threading
import time

import numpy as np

from openpendant.device_drivers.ur_rtde.emulator import wire
from openpendant.device_drivers.ur_rtde.emulator.controller import (
    IDLE,
    NORMAL,
    PLAYING,
    POWER_OFF,
    PROTECTIVE_STOP,
    RUNNING,
    Controller,
)

log = logging.getLogger(__name__)
RTDE_PORT, DASHBOARD_PORT, SCRIPT_PORT = 30004, 29999, 30003


class RtdeSession:
    """One client's connection: its output recipe, its input recipes (numbered 1, 2, … in
    the order they were set up, as ur-rtde counts them) and the stream once started."""

    def __init__(
        self, controller: Controller, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
    ) -> None:
        self.controller, self.reader, self.writer = controller, reader, writer
        self.output: tuple[list[str], list[str]] | None = None  # names, types
        self.frequency = 125.0
        self.inputs: dict[int, tuple[list[str], list[str]]] = {}
        self.streaming: asyncio.Task[None] | None = None

    def send(self, kind: int, payload: bytes = b"") -> None:
        self.writer.write(wire.package(kind, payload))

    async def serve(self) -> None:
        try:
            while True:
                header = await self.reader.readexactly(3)
                size, kind = struct.unpack(">HB", header)
                body = await self.reader.readexactly(size - 3)
                self.handle(kind, body)
                await self.writer.drain()
        except (asyncio.IncompleteReadError, ConnectionError):
            pass
        finally:
            if self.streaming is not None:
                self.streaming.cancel()
            owners = self.controller.input_owners
            for name in [n for n, owner in owners.items() if owner is self]:
                del owners[name]
            self.writer.close()

    def handle(self, kind: int, body: bytes) -> None:
        c = self.controller
        if kind == wire.V:
            self.send(wire.V, b"\x01")
        elif kind == wire.v:
            self.send(wire.v, struct.pack(">IIII", *c.version))
        elif kind == wire.O:
            (self.frequency,) = struct.unpack_from(">d", body)
            names = wire.names(body[8:])
            types = [wire.OUTPUTS.get(n, "NOT_FOUND") for n in names]
            if "NOT_FOUND" not in types:
                self.output = (names, types)
            self.send(wire.O, b"\x01" + ",".join(types).encode())
        elif kind == wire.I:
            names = wire.names(body)
            types = [wire.INPUTS.get(n, "NOT_FOUND") for n in names]
            # A controller gives each input field to one connection at a time.
            claimed = c.input_owners
            if any(claimed.get(n, self) is not self for n in names):
                taken = [
                    "IN_USE" if claimed.get(n, self) is not self else t
                    for n, t in zip(names, types, strict=True)
                ]
                self.send(wire.I, b"\x00" + ",".join(taken).encode())
                return
            claimed.update(dict.fromkeys(names, self))
            number = len(self.inputs) + 1
            self.inputs[number] = (names, types)
            self.send(wire.I, bytes([number]) + ",".join(types).encode())
        elif kind == wire.S:
            self.send(wire.S, b"\x01")
            if self.output is not None and self.streaming is None:
                self.streaming = asyncio.create_task(self.stream())
        elif kind == wire.P:
            if self.streaming is not None:
                self.streaming.cancel()
                self.streaming = None
            self.send(wire.P, b"\x01")
        elif kind == wire.U and body:
            recipe = self.inputs.get(body[0])
            if recipe is not None:
                names, types = recipe
                values = wire.decode(types, body[1:])
                c.apply_inputs(dict(zip(names, values, strict=False)))

    async def stream(self) -> None:
        """Data packages at the recipe's rate from a thread of their own, on time to a
        fraction of a millisecond (an event loop's timers are not: late packages arrive in
        pairs, and ur-rtde keeps only the newer of two)."""
        assert self.output is not None
        await self.writer.drain()  # the 'S' reply out first: from here the thread writes
        sock = self.writer.get_extra_info("socket")
        out = socket.socket(fileno=os.dup(sock.fileno()))
        out.setblocking(True)
        running = threading.Event()
        running.set()
        thread = threading.Thread(
            target=self._send_loop, args=(out, running), name="rtde-stream", daemon=True
        )
        thread.start()
        try:
            await asyncio.Event().wait()  # until cancelled (pause, or the connection ends)
        finally:
            running.clear()
            await asyncio.to_thread(thread.join, 1.0)
            out.close()

    def _send_loop(self, out: socket.socket, running: threading.Event) -> None:
        assert self.output is not None
        names, types = self.output
        period = 1.0 / max(self.frequency, 1.0)
        next_at = time.monotonic()
        while running.is_set():
            values = self.controller.outputs()
            data = wire.package(
                wire.U, b"\x01" + wire.encode(types, [values.get(n) for n in names])
            )
            try:
                out.sendall(data)
            except OSError:
                return
            next_at += period
            delay = next_at - time.monotonic()
            if delay < -10 * period:  # stalled (the machine was busy): start afresh
                next_at, delay = time.monotonic(), 0.0
            if delay > 0:
                time.sleep(delay)


class Emulator:
    """The three servers around one controller, on `host`."""

    def __init__(self, controller: Controller, host: str = "127.0.0.2") -> None:
        self.controller, self.host = controller, host
        self._servers: list[asyncio.Server] = []
        self.stalled = 0.0  # monotonic time until which the dashboard answers nothing

    async def start(self) -> None:
        self.controller.run()
        self._servers = [
            await asyncio.start_server(self._rtde, self.host, RTDE_PORT, reuse_address=True),
            await asyncio.start_server(
                self._dashboard, self.host, DASHBOARD_PORT, reuse_address=True
            ),
            await asyncio.start_server(self._script, self.host, SCRIPT_PORT, reuse_address=True),
        ]

    async def stop(self) -> None:
        for server in self._servers:
            server.close()
            with contextlib.suppress(Exception):
                await asyncio.wait_for(server.wait_closed(), 1.0)
        self.controller.close()

    async def _rtde(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await RtdeSession(self.controller, reader, writer).serve()

    async def _script(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        """Scripts arrive as text; a program ends with its top-level `end`."""
        text = ""
        try:
            while line := await reader.readline():
                text += line.decode("utf-8", "replace")
                if line.rstrip(b"\r\n") == b"end":
                    self.controller.script_received(text)
                    text = ""
        except ConnectionError:
            pass
        finally:
            writer.close()

    async def _dashboard(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        writer.write(b"Connected: Universal Robots Dashboard Server\n")
        try:
            while line := await reader.readline():
                command = line.decode("utf-8", "replace").strip()
                if not command.startswith("emulator "):  # the test's own line always answers
                    await asyncio.sleep(max(self.stalled - time.monotonic(), 0.0))  # hung
                reply = self.dashboard(command)
                writer.write(reply.encode() + b"\n")
                await writer.drain()
        except ConnectionError:
            pass
        finally:
            writer.close()

    def dashboard(self, command: str) -> str:
        c = self.controller
        major, minor, bugfix, build = c.version
        with c.lock:
            if command == "PolyscopeVersion":
                return f"URSoftware {major}.{minor}.{bugfix}.{build} (Jan 01 2026)"
            if command == "get serial number":
                return c.serial
            if command == "get operational mode":
                return c.operational_mode
            if command == "is in remote control":
                return "true"
            if command == "get robot model":  # the family: UR5 for a UR5e too
                return re.sub(r"E$", "", c.info.model.upper())
            if command == "robotmode":
                return f"Robotmode: {ROBOT_MODES.get(c.robot_mode, 'UNKNOWN')}"
            if command == "safetymode" or command == "safetystatus":
                word = "Safetymode" if command == "safetymode" else "Safetystatus"
                return f"{word}: {SAFETY_MODES.get(c.safety_mode, 'UNKNOWN')}"
            if command == "programState":
                return "PLAYING rtde_control" if c.runtime_state == PLAYING else "STOPPED <unnamed>"
            if command == "running":
                return f"Program running: {str(c.runtime_state == PLAYING).lower()}"
            if command == "power on":
                if c.robot_mode == POWER_OFF and c.safety_mode == NORMAL:
                    c.robot_mode = IDLE
                return "Powering on"
            if command == "power off":
                c.robot_mode = POWER_OFF
                c.stop_program()
                return "Powering off"
            if command == "brake release":
                if c.robot_mode == IDLE:
                    c.robot_mode = RUNNING
                return "Brake releasing"
            if command == "unlock protective stop":
                if c.safety_mode == PROTECTIVE_STOP:
                    c.safety_mode = NORMAL
                return "Protective stop releasing"
            if command == "close safety popup":
                return "closing safety popup"
            if command == "close popup":
                return "closing popup"
            if command == "stop":
                c.stop_program()
                return "Stopped"
            if command.startswith("emulator "):
                return self.world(command.removeprefix("emulator "))
            if re.fullmatch(r"popup .*|addToLog .*", command):
                return "showing popup" if command.startswith("popup") else "Added log message"
        return f"could not understand: '{command}'"

    def world(self, command: str) -> str:
        """What happens around the robot (tests only; a real dashboard knows none of it):
        `protective stop`, `estop on|off`, `reduced on|off` (the safety system's reduced
        limits), `dashboard stall S` (the dashboard answers nothing else for S seconds),
        `digital input N on|off` (0-7 standard, 8-15 configurable, 16-17 tool), `analog
        input N VALUE` (in the input's unit, V or mA), `operational mode manual|automatic|none` (the
        pendant's mode selection), `hand V1 … V6` (a hand pushing the arm at these joint
        velocities: it moves only in teach mode), `reset` (powered, normal, no program,
        nothing held), `place Q1 … Q6` (the arm put there at rest, if it is still: a test's
        set-up), `record on` (record the arm's joint positions, one a cycle), `record off`
        (stop: the recording, a JSON list), `state`."""
        c = self.controller
        words = command.split()
        if command == "protective stop":
            c.protective_stop()
        elif command == "reset":
            c.reset()
        elif words[:1] == ["record"] and words[1:] in (["on"], ["off"]):
            recorded = c.record(words[1] == "on")
            if words[1] == "off":
                return json.dumps(recorded)
        elif words[:1] == ["estop"] and words[1:] in (["on"], ["off"]):
            c.emergency_stop(words[1] == "on")
        elif words[:1] == ["reduced"] and words[1:] in (["on"], ["off"]):
            c.reduced_mode(words[1] == "on")
        elif words[:2] == ["dashboard", "stall"] and len(words) == 3:
            try:
                seconds = float(words[2])
            except ValueError:
                return f"emulator: not a number: {command!r}"
            self.stalled = time.monotonic() + min(max(seconds, 0.0), 60.0)
        elif words[:2] == ["digital", "input"] and len(words) == 4 and words[2].isdigit():
            bit = 1 << int(words[2])
            c.digital_inputs = (
                (c.digital_inputs | bit) if words[3] == "on" else (c.digital_inputs & ~bit)
            )
        elif words[:2] == ["analog", "input"] and len(words) == 4 and words[2] in ("0", "1"):
            try:
                value = float(words[3])
            except ValueError:
                return f"emulator: not a number: {command!r}"
            if not np.isfinite(value):
                return f"emulator: not finite: {command!r}"
            c.analog_inputs[int(words[2])] = value
        elif words[:2] == ["operational", "mode"] and words[2:] in (
            ["manual"],
            ["automatic"],
            ["none"],
        ):
            c.operational_mode = words[2].upper()
        elif words[:1] == ["hand"] and len(words) == len(c.hand) + 1:
            try:
                push = np.array([float(w) for w in words[1:]])
            except ValueError:
                return f"emulator: not numbers: {command!r}"
            if not np.all(np.isfinite(push)):
                return f"emulator: not finite: {command!r}"
            c.hand = np.clip(push, -c.tracker.max_velocity, c.tracker.max_velocity)
        elif words[:1] == ["place"] and len(words) == len(c.hand) + 1:
            try:
                position = np.array([float(w) for w in words[1:]])
            except ValueError:
                return f"emulator: not numbers: {command!r}"
            if not np.all(np.isfinite(position)):
                return f"emulator: not finite: {command!r}"
            if not c.place(position):
                return "emulator: the arm is moving"
        elif command == "state":
            return json.dumps(
                {
                    "q": c.tracker.position.tolist(),
                    "qd": c.tracker.velocity.tolist(),
                    "runtime_state": c.runtime_state,
                    "robot_mode": c.robot_mode,
                    "safety_mode": c.safety_mode,
                    "watchdog_hz": c.watchdog_hz,
                    "freedrive": c.freedrive,
                    "commands": c.commands[-50:],
                    "started_at": c.started_at,
                    "scripts": c.scripts,
                    "digital_outputs": c.digital_outputs,
                    "analog_outputs": [c.analog_out(0), c.analog_out(1)],
                }
            )
        else:
            return f"emulator: unknown {command!r}"
        return "ok"


ROBOT_MODES = {
    -1: "NO_CONTROLLER",
    0: "DISCONNECTED",
    1: "CONFIRM_SAFETY",
    2: "BOOTING",
    3: "POWER_OFF",
    4: "POWER_ON",
    5: "IDLE",
    6: "BACKDRIVE",
    7: "RUNNING",
}
SAFETY_MODES = {
    1: "NORMAL",
    2: "REDUCED",
    3: "PROTECTIVE_STOP",
    4: "RECOVERY",
    5: "SAFEGUARD_STOP",
    6: "SYSTEM_EMERGENCY_STOP",
    7: "ROBOT_EMERGENCY_STOP",
    8: "VIOLATION",
    9: "FAULT",
}
