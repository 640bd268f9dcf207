"""The runtime's side of one program run: start the worker, answer its requests through the
host, relay pause/resume/step/breakpoints, collect output, and stop it - kill the worker
and halt what it commanded - on request, on the wall-clock limit, or when it breaks the
protocol."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import logging
import os
import signal
import sys
import time
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from enum import StrEnum
from functools import cache
from typing import Any, Protocol

from openpendant.plugins.registry import registry
from openpendant.runtime.kit.words import Words, words, words_of
from openpendant.sandbox.protocol import (
    FUNCTIONS_ENV,
    ISOLATION,
    MAX_LINE_BYTES,
    MAX_OUTPUT_CHARS,
    ProtocolError,
    decode,
    encode,
)

log = logging.getLogger(__name__)

KEEP_OUTPUT = 1000
STDERR_TAIL = 4096


class RunState(StrEnum):
    starting = "starting"
    running = "running"
    paused = "paused"
    stopped = "stopped"
    error = "error"
    finished = "finished"


ENDED = (RunState.stopped, RunState.error, RunState.finished)


class CallRefused(Exception):
    """What a host raises to refuse a program's request; the program gets the message."""

    def __init__(self, message: str, code: str = "error", said: Words | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.code = code
        self.words = said


class Host(Protocol):
    async def call(self, fn: str, args: dict[str, Any]) -> Any: ...

    async def halt(self) -> None:
        """Halt every device this run commanded, at once."""


@dataclass(frozen=True)
class RunLimits:
    wall_seconds: float = 8 * 3600.0
    cpu_seconds: int = 3600
    memory_mb: int = 256


@dataclass
class OutputLine:
    seq: int
    text: str
    stream: str  # out | info | warning | error | system
    block: str | None
    ts: float = field(default_factory=time.time)
    words: Words | None = None  # an error line as a UI says it in its language


@dataclass
class RunError:
    message: str
    kind: str
    line: int | None = None
    block: str | None = None
    code: str | None = None
    words: Words | None = None  # the message as a UI says it in its language


Listener = Callable[[], None]
Process = asyncio.subprocess.Process


# All a worker is given of the runtime's environment: where Python finds packages and how it
# runs. Never the rest: it holds the runtime's internal token, the first start's set-up code
# and device secrets, which one escape from the interpreter would otherwise hand over.
WORKER_PASSES = (
    "PYTHONPATH",
    "PYTHONDONTWRITEBYTECODE",
    "PYTHONSAFEPATH",
    "LANG",
    "LC_ALL",
    "TZ",
    # One BLAS thread, as in every runtime process (a pool per core would be started before
    # the worker limits itself).
    "OPENBLAS_NUM_THREADS",
    "OMP_NUM_THREADS",
)


@cache
def worker_env() -> dict[str, str]:
    """The worker's environment, built from nothing: the variables above, and the plugins'
    sandbox functions named, so the worker imports just those instead of reading every
    installed package's entry points."""
    functions = {
        name: reference
        for block in registry().blocks.values()
        for name, reference in block.functions.items()
    }
    passed = {name: os.environ[name] for name in WORKER_PASSES if name in os.environ}
    return {"PATH": os.defpath, **passed, FUNCTIONS_ENV: json.dumps(functions)}


async def spawn_worker(limits: str) -> Process:
    return await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "openpendant.sandbox.worker",
        limits,
        stdin=asyncio.subprocess.PIPE,
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
        limit=MAX_LINE_BYTES + 1,
        env=worker_env(),
    )


_said: list[tuple[str, ...]] = []


def say_isolation(granted: list[str]) -> None:
    """One log line, at the first run and whenever it changes: what the host granted a
    program's worker, and what not."""
    missing = tuple(i for i in ISOLATION if i not in granted)
    if _said == [missing]:
        return
    _said[:] = [missing]
    if missing:
        log.warning(
            "program workers run with %s; this host does not grant %s",
            ", ".join(granted),
            ", ".join(missing),
        )
    else:
        log.info("program workers run with every limit: %s", ", ".join(granted))


# A new worker's start-up is ~100 ms of CPU: not while the run just taken makes its first move.
REFILL_DELAY = 0.5  # s


class WorkerPool:
    """One worker started ahead: Python's start-up and imports take ~100 ms, which a run
    request should not wait for. A spare holds no program until it is taken."""

    def __init__(self) -> None:
        self._spare: tuple[str, Process] | None = None
        self._refill: asyncio.Task[None] | None = None

    async def take(self, limits: str) -> Process:
        spare, self._spare = self._spare, None
        if spare is not None and spare[0] == limits and spare[1].returncode is None:
            process = spare[1]
        else:
            if spare is not None:
                _kill(spare[1])
            process = await spawn_worker(limits)
        if self._refill is not None:
            self._refill.cancel()  # one refill at a time: close() must find every one
        self._refill = asyncio.ensure_future(self._fill(limits))
        return process

    async def _fill(self, limits: str) -> None:
        await asyncio.sleep(REFILL_DELAY)
        process = await spawn_worker(limits)
        if self._spare is None:
            self._spare = (limits, process)
        else:
            _kill(process)

    async def close(self) -> None:
        if self._refill is not None:
            self._refill.cancel()
        if self._spare is not None:
            _kill(self._spare[1])
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._spare[1].wait(), 2.0)
            self._spare = None


def _kill(process: Process) -> None:
    if process.returncode is None:
        with contextlib.suppress(ProcessLookupError):
            process.kill()


class ProgramRun:
    def __init__(
        self,
        source: str,
        host: Host,
        *,
        limits: RunLimits | None = None,
        breakpoints: set[str] | None = None,
        listener: Listener | None = None,
        pool: WorkerPool | None = None,
    ) -> None:
        self.pool = pool
        self.source = source
        self.host = host
        self.limits = limits or RunLimits()
        self.breakpoints = set(breakpoints or ())
        self.listener = listener
        self._calls_in_flight = 0
        self.state = RunState.starting
        self.block: str | None = None
        self.pause_reason = ""
        self.message = ""
        self.error: RunError | None = None
        self.isolation: list[str] = []
        self.output: deque[OutputLine] = deque(maxlen=KEEP_OUTPUT)
        self.started = time.time()
        self.ended: float | None = None
        self._seq = itertools.count(1)
        self._process: Process | None = None
        self._tasks: set[asyncio.Task[Any]] = set()
        self._done = asyncio.Event()
        self._stopping = False
        self._stderr = b""

    # Control -------------------------------------------------------------------------------

    async def start(self) -> None:
        limits = {"memory_mb": self.limits.memory_mb, "cpu_seconds": self.limits.cpu_seconds}
        text = json.dumps(limits, sort_keys=True)
        self._process = await (self.pool.take(text) if self.pool else spawn_worker(text))
        await self._send(
            {"t": "start", "source": self.source, "breakpoints": sorted(self.breakpoints)}
        )
        self._spawn(self._read())
        self._spawn(self._drain_stderr())
        self._spawn(self._watchdog())

    @property
    def ended_state(self) -> bool:
        return self.state in ENDED

    async def pause(self) -> None:
        self._require_live()
        await self._send({"t": "pause"})
        # Inside a call (a move), the run is paused now: its robots are stopping on their
        # paths, and the worker reaches its next block only once the call returns.
        if self.state is RunState.running and self._calls_in_flight:
            self.state, self.pause_reason = RunState.paused, "pause"
            self._notify()

    async def resume(self) -> None:
        self._require_live()
        await self._send({"t": "resume"})
        self._running_again()

    async def step(self) -> None:
        self._require_live()
        await self._send({"t": "step"})
        self._running_again()

    def _running_again(self) -> None:
        if self.state is RunState.paused:
            self.state, self.pause_reason, self.message = RunState.running, "", ""
            self._notify()

    async def set_breakpoints(self, ids: set[str]) -> None:
        self.breakpoints = set(ids)
        if not self.ended_state:
            await self._send({"t": "breakpoints", "ids": sorted(self.breakpoints)})

    async def stop(self, reason: str = "stopped by the operator") -> None:
        """Stop wins: kill the worker and halt the devices, whatever it was doing."""
        if self.ended_state or self._stopping:
            return
        self._stopping = True
        self._kill()
        try:
            await self.host.halt()
        finally:
            self._end(RunState.stopped, reason)
            self._cancel_tasks()

    async def wait(self, timeout: float | None = None) -> RunState:
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self._done.wait(), timeout)
        return self.state

    def _require_live(self) -> None:
        if self.ended_state:
            raise RuntimeError(f"the run has ended ({self.state})")

    # Worker messages -----------------------------------------------------------------------

    async def _read(self) -> None:
        assert self._process is not None
        assert self._process.stdout is not None
        stdout = self._process.stdout
        try:
            while True:
                try:
                    line = await stdout.readline()
                except (ValueError, asyncio.LimitOverrunError):
                    raise ProtocolError("a message from the worker is too long") from None
                if not line:
                    break
                await self._handle(decode(line))
        except ProtocolError as exc:
            said = words("run.protocol", reason=str(exc))
            await self._halt_and_fail(
                RunError(f"the program broke the worker protocol: {exc}", "protocol", words=said)
            )
            return
        await self._process.wait()
        if not self.ended_state:
            await self._halt_and_fail(self._worker_death())

    async def _handle(self, message: dict[str, Any]) -> None:
        kind = message["t"]
        if kind == "ready":
            self.isolation = [str(i) for i in message.get("isolation", [])]
            say_isolation(self.isolation)
            self.state = RunState.running
        elif kind == "block":
            self.block = _block(message.get("id"))
        elif kind == "paused":
            self.block = _block(message.get("block"))
            self.state = RunState.paused
            self.pause_reason = str(message.get("reason", "pause"))
            self.message = str(message.get("message", ""))[:MAX_OUTPUT_CHARS]
        elif kind == "resumed":
            self.state, self.pause_reason, self.message = RunState.running, "", ""
        elif kind == "call":
            self.block = _block(message.get("block"))
            self._spawn(self._answer(message))
        elif kind == "output":
            self._add_output(str(message.get("text", "")), message.get("stream"), message)
        elif kind == "error":
            text = str(message.get("message", "error"))[:MAX_OUTPUT_CHARS]
            error_kind = str(message.get("kind", "error"))
            error = RunError(
                message=text,
                kind=error_kind,
                line=message.get("line") if isinstance(message.get("line"), int) else None,
                block=_block(message.get("block")),
                code=str(message["code"]) if message.get("code") else None,
                words=words_of(message.get("words")) or _error_words(error_kind, text),
            )
            await self._halt_and_fail(error)
        elif kind == "done":
            stopped = bool(message.get("stopped"))
            self._end(RunState.finished, "ended by stop program" if stopped else "finished")
        else:
            raise ProtocolError(f"unknown message {kind!r}")
        self._notify()

    async def _answer(self, message: dict[str, Any]) -> None:
        self._calls_in_flight += 1
        try:
            await self._answer_call(message)
        finally:
            self._calls_in_flight -= 1

    async def _answer_call(self, message: dict[str, Any]) -> None:
        call_id = message.get("id")
        fn, args = message.get("fn"), message.get("args")
        if not isinstance(fn, str) or not isinstance(args, dict):
            reply: dict[str, Any] = {
                "ok": False,
                "error": {"code": "bad_call", "message": "malformed call"},
            }
        else:
            try:
                reply = {"ok": True, "value": await self.host.call(fn, args)}
            except CallRefused as exc:
                error: dict[str, Any] = {"code": exc.code, "message": exc.message}
                if exc.words is not None:
                    error["words"] = exc.words.body()
                reply = {"ok": False, "error": error}
        if not self.ended_state:
            with contextlib.suppress(ProtocolError, ConnectionError, RuntimeError):
                await self._send({"t": "reply", "id": call_id, **reply})

    async def _drain_stderr(self) -> None:
        """Keep the tail of what the worker wrote to stderr (a crash's traceback)."""
        assert self._process is not None
        assert self._process.stderr is not None
        while chunk := await self._process.stderr.read(4096):
            self._stderr = (self._stderr + chunk)[-STDERR_TAIL:]

    async def _watchdog(self) -> None:
        await asyncio.sleep(self.limits.wall_seconds)
        if not self.ended_state:
            limit = self.limits.wall_seconds
            said = words("run.timeout", seconds=limit)
            await self._halt_and_fail(
                RunError(f"the run took longer than {limit:g} s", "timeout", words=said)
            )

    async def _halt_and_fail(self, error: RunError) -> None:
        if self.ended_state or self._stopping:
            return
        self._stopping = True
        self._kill()
        self.error = error
        if error.block is not None:
            self.block = error.block
        line = f" (line {error.line})" if error.line else ""
        said = error.words
        if said is not None and error.line:
            said = words("run.at_line", message=said, line=error.line)
        self._add_output(f"{error.message}{line}", "error", {"block": error.block}, said)
        try:
            await self.host.halt()
        except Exception:  # the error is the news; a failed halt is logged
            log.exception("halting after a program error failed")
        self._end(RunState.error, error.message)
        self._cancel_tasks(keep=asyncio.current_task())

    def _worker_death(self) -> RunError:
        assert self._process is not None
        code = self._process.returncode
        if code is not None and code < 0:
            name = signal.Signals(-code).name
            if -code == signal.SIGXCPU:
                seconds = self.limits.cpu_seconds
                return RunError(
                    f"the program used its {seconds} s of CPU time",
                    "cpu_limit",
                    words=words("run.cpu_limit", seconds=seconds),
                )
            return RunError(
                f"the program's worker was killed ({name}); out of memory?",
                name,
                words=words("run.killed", signal=name),
            )
        tail = self._stderr.decode(errors="replace").strip().splitlines()[-1:]
        detail = f": {tail[0]}" if tail else ""
        return RunError(
            f"the program's worker ended unexpectedly (exit {code}){detail}",
            "worker",
            words=words("run.worker_ended", exit=str(code), detail=detail),
        )

    # Helpers -------------------------------------------------------------------------------

    async def _send(self, message: dict[str, Any]) -> None:
        if self._process is None or self._process.stdin is None:
            raise RuntimeError("the worker is not running")
        self._process.stdin.write(encode(message))
        with contextlib.suppress(ConnectionError):
            await self._process.stdin.drain()

    def _add_output(
        self, text: str, stream: Any, message: dict[str, Any], said: Words | None = None
    ) -> None:
        kind = stream if stream in ("out", "info", "warning", "error", "system") else "out"
        block = _block(message.get("block"))
        self.output.append(
            OutputLine(next(self._seq), text[:MAX_OUTPUT_CHARS], kind, block, words=said)
        )

    def _kill(self) -> None:
        if self._process is not None:
            _kill(self._process)

    def _end(self, state: RunState, message: str) -> None:
        if self.ended_state:
            return
        self.state, self.message, self.ended = state, message, time.time()
        self._done.set()
        self._notify()

    def _spawn(self, coro: Awaitable[Any]) -> None:
        task: asyncio.Task[Any] = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    def _cancel_tasks(self, keep: asyncio.Task[Any] | None = None) -> None:
        for task in list(self._tasks):
            if task is not keep and task is not asyncio.current_task():
                task.cancel()

    def _notify(self) -> None:
        if self.listener is not None:
            self.listener()

    async def close(self) -> None:
        self._kill()
        self._cancel_tasks()
        if self._process is not None:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._process.wait(), 2.0)


def _block(value: Any) -> str | None:
    return value[:64] if isinstance(value, str) else None


def _error_words(kind: str, message: str) -> Words:
    """A program's error the runtime did not word: Python's own ("ZeroDivisionError: …"),
    the compiler's, or a sandbox function's check of its arguments."""
    return words("run.compile" if kind == "compile" else "run.exception", error=message)
