"""How the simulated devices of one installation reach the world of the simulated robot
their gripper or sensors belong to: a Unix socket in Linux's abstract namespace, named by
the data directory and the robot's name (no port to hand around, nothing left on disk),
one JSON line asked, one answered."""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import json
import logging
import os
import socket
from pathlib import Path
from typing import Any

from openpendant.device_drivers.sim_cell.world import CellSetup, World
from openpendant.runtime.kit.settings import SETTINGS_ENV, load_settings, settings_from_env

log = logging.getLogger(__name__)
TIMEOUT = 0.5  # s; the world is in a process on this computer
MAX_LINE = 64 * 1024


def _data_dir() -> Path:
    settings = settings_from_env() if os.environ.get(SETTINGS_ENV) else load_settings(None)
    return settings.data_dir


def address(robot: str, data_dir: Path | None = None) -> str:
    where = str((data_dir or _data_dir()).resolve())
    return f"\0openpendant-cell/{hashlib.sha256(where.encode()).hexdigest()[:16]}/{robot}"


class CellServer:
    """The world, answering the simulated devices beside the robot."""

    def __init__(self, world: World, robot: str) -> None:
        self.world, self.robot = world, robot
        self._server: asyncio.Server | None = None

    async def start(self) -> None:
        # The socket made here, not by the loop: uvloop (uvicorn's loop) refuses abstract
        # names given as paths.
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            sock.bind(address(self.robot))
            sock.listen(16)
        except OSError:
            sock.close()
            raise
        self._server = await asyncio.start_unix_server(self._serve, sock=sock, limit=MAX_LINE)

    async def stop(self) -> None:
        if self._server is not None:
            self._server.close()
            await self._server.wait_closed()

    def answer(self, request: dict[str, Any]) -> dict[str, Any]:
        op = request.get("op")
        if op == "grasp":
            opening = float(request.get("opening", 0.0))
            part = self.world.grasp(opening)
            return {"part": part.model_dump() if part else None}
        if op == "release":
            part = self.world.release()
            return {"part": part.model_dump() if part else None}
        if op == "sensed":
            return {"sensors": self.world.sensed()}
        if op == "parts":
            return {"parts": [p.model_dump() for p in self.world.snapshot()]}
        if op == "scene":
            return self.world.scene()
        if op == "layout":  # a simulator without HTTP routes of its own (the UR emulator)
            self.world.replace(CellSetup.model_validate(request.get("setup")))
            return {"parts": [p.model_dump() for p in self.world.snapshot()]}
        return {"error": f"unknown op {op!r}"}

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            while line := await reader.readline():
                try:
                    reply = self.answer(json.loads(line))
                except (ValueError, TypeError) as exc:  # ValidationError is a ValueError
                    reply = {"error": str(exc)}
                writer.write(json.dumps(reply).encode() + b"\n")
                await writer.drain()
        except (ConnectionError, asyncio.LimitOverrunError, ValueError):
            pass
        finally:
            writer.close()


class CellClient:
    """A simulated device's side: asks the world of the robot named `robot`; without one
    (no such simulated robot running) every answer is None, as if nothing were there."""

    def __init__(self, robot: str, data_dir: Path | None = None) -> None:
        self.robot = robot
        self.data_dir = data_dir  # None: this process's
        self._missing_said = False

    async def ask(self, op: str, **args: Any) -> dict[str, Any] | None:
        try:
            async with asyncio.timeout(TIMEOUT):
                sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                try:
                    sock.connect(address(self.robot, self.data_dir))  # local: at once or refused
                except OSError:
                    sock.close()
                    raise
                reader, writer = await asyncio.open_unix_connection(sock=sock)
                try:
                    writer.write(json.dumps({"op": op, **args}).encode() + b"\n")
                    await writer.drain()
                    reply: dict[str, Any] = json.loads(await reader.readline())
                finally:
                    writer.close()
                    with contextlib.suppress(ConnectionError):
                        await writer.wait_closed()
        except (OSError, TimeoutError, ValueError) as exc:
            if not self._missing_said:
                log.warning("no simulated cell of %s: %s", self.robot, exc)
                self._missing_said = True
            return None
        self._missing_said = False
        return reply
