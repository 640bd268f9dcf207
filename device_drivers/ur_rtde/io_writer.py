"""Output writes to a UR controller from a process of their own.

ur-rtde's RTDEIOInterface holds Python's interpreter lock for the whole of its constructor
(it connects, then sleeps 100 ms): made in the driver's process it stops every thread of it
for that long, the arm driver's control thread too, whose silence the RTDE watchdog (10 Hz)
punishes by stopping the control program. Its destructor also aborts the process once its
connection has died. So each write runs here, in a child process that owns nothing else:
one JSON line in (`{"call": "setToolDigitalOut", "args": [0, true]}`), one line out
(`{"ok": true}` or `{"error": …, "code": …}`).

A controller gives each RTDE input field to one connection at a time; a write that finds
them taken (the arm driver and the I/O driver writing at once) is tried again for a while."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import sys
import time
from collections.abc import Callable
from typing import Any

from openpendant.device_drivers.ur_rtde.link import write_outputs
from openpendant.runtime.kit.errors import OpenPendantError, RobotError, Unavailable

log = logging.getLogger(__name__)

CALLS = frozenset(
    {
        "setStandardDigitalOut",
        "setConfigurableDigitalOut",
        "setToolDigitalOut",
        "setAnalogOutputVoltage",
        "setAnalogOutputCurrent",
    }
)
IN_USE_FOR = 2.0  # s: how long a write waits for another connection to give up the fields
ANSWER_WITHIN = 15.0  # s: connecting to an unreachable controller takes ur-rtde a while


def serve(host: str) -> None:
    """The child's side: every request line on stdin, its answer on stdout."""
    for line in sys.stdin:
        try:
            request = json.loads(line)
            call, args = request["call"], request["args"]
            if call not in CALLS or not isinstance(args, list):
                raise ValueError(f"not a write: {line[:80]!r}")
            deadline = time.monotonic() + IN_USE_FOR
            write = _bound(call, args)
            while True:
                try:
                    write_outputs(host, write)
                    break
                except RuntimeError as exc:
                    if "already in use" not in str(exc) or time.monotonic() > deadline:
                        raise
                    time.sleep(0.02)
            answer: dict[str, object] = {"ok": True}
        except RuntimeError as exc:
            if "already in use" not in str(exc):
                answer = {"error": str(exc), "code": "io"}
            else:
                answer = {
                    "error": f"another connection held the controller's outputs for over "
                    f"{IN_USE_FOR:g} s (an EtherNet/IP, PROFINET or Modbus unit configured on "
                    "the controller, or another RTDE client): nothing was written",
                    "code": "outputs_in_use",
                }
        except RobotError as exc:
            answer = {"error": exc.message, "code": exc.code}
        except Exception as exc:  # ur-rtde's own (no connection, refused), or a bad line
            answer = {"error": str(exc), "code": "io"}
        print(json.dumps(answer), flush=True)


def _bound(call: str, args: list[object]) -> Callable[[Any], object]:
    return lambda io: getattr(io, call)(*args)


class OutputWriter:
    """The driver's side: the child started on the first write and again after it died."""

    def __init__(self, host: str) -> None:
        self.host = host
        self._child: asyncio.subprocess.Process | None = None
        self._lock = asyncio.Lock()  # one write at a time

    async def call(self, method: str, *args: bool | int | float) -> None:
        async with self._lock:
            child = await self._started()
            if child.stdin is None or child.stdout is None:
                raise RuntimeError("the writer was started without its pipes")
            child.stdin.write((json.dumps({"call": method, "args": list(args)}) + "\n").encode())
            try:
                async with asyncio.timeout(ANSWER_WITHIN):
                    await child.stdin.drain()
                    line = await child.stdout.readline()
            except (TimeoutError, ConnectionError):
                line = b""
            if not line:
                await self._end(child)
                raise Unavailable(
                    f"the I/O connection to {self.host} failed: nothing was confirmed",
                    code="disconnected",
                )
        answer = json.loads(line)
        if "error" in answer:
            raise OpenPendantError(
                f"{self.host}: {answer['error']}", code=str(answer["code"]), status=502
            )

    async def _started(self) -> asyncio.subprocess.Process:
        if self._child is None or self._child.returncode is not None:
            self._child = await asyncio.create_subprocess_exec(
                sys.executable,
                "-m",
                "openpendant.device_drivers.ur_rtde.io_writer",
                self.host,
                stdin=asyncio.subprocess.PIPE,
                stdout=asyncio.subprocess.PIPE,
            )
        return self._child

    async def _end(self, child: asyncio.subprocess.Process) -> None:
        with contextlib.suppress(ProcessLookupError):
            child.kill()
        await child.wait()
        self._child = None

    async def close(self) -> None:
        child, self._child = self._child, None
        if child is None or child.returncode is not None:
            return
        if child.stdin is not None:
            child.stdin.close()  # it ends when its input does
        try:
            async with asyncio.timeout(3.0):
                await child.wait()
        except TimeoutError:
            await self._end(child)


if __name__ == "__main__":
    logging.basicConfig(level=logging.WARNING)
    serve(sys.argv[1])
