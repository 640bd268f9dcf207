"""The worker process that runs one program: `python -m openpendant.sandbox.worker <limits JSON>`.

It limits itself before it reads any program code (memory, CPU, files, processes; its own
network and mount namespaces, a read-only view of the files, an unprivileged user, no new
privileges and a filter of the system calls it may make, where the system allows), then
talks to the runtime only over its stdin/stdout pipes: the runtime answers every device request, and
sends pause, resume, step and breakpoints, which take effect at the next block marker."""

from __future__ import annotations

import contextlib
import importlib
import json
import os
import resource
import sys
import threading
import time
import traceback
import unicodedata  # noqa: F401  # compiling a non-ASCII name imports it: not after close_off
from dataclasses import dataclass, field
from typing import Any, BinaryIO

from openpendant.sandbox import syscalls
from openpendant.sandbox.builtins import safe_builtins
from openpendant.sandbox.guards import guard_globals
from openpendant.sandbox.library import REGISTRY
from openpendant.sandbox.library.base import ProgramError, bind
from openpendant.sandbox.policy import PROGRAM_FILENAME, ProgramCompileError, compile_program
from openpendant.sandbox.protocol import (
    FUNCTIONS_ENV,
    MAX_OUTPUT_CHARS,
    ProtocolError,
    decode,
    encode,
)

NOBODY = 65534
BLOCK_REPORT_INTERVAL = 0.01  # s between unprompted block reports (a tight loop floods)
OUTPUT_PER_SECOND = 200  # printed lines; beyond this the program is slowed down
SLEEP_SLICE = 0.02


@dataclass
class Limits:
    memory_mb: int = 256
    cpu_seconds: int = 3600
    nice: int = 5

    @classmethod
    def from_json(cls, text: str) -> Limits:
        raw = json.loads(text)
        return cls(
            memory_mb=int(raw.get("memory_mb", cls.memory_mb)),
            cpu_seconds=int(raw.get("cpu_seconds", cls.cpu_seconds)),
            nice=int(raw.get("nice", cls.nice)),
        )


def isolate_process(limits: Limits) -> list[str]:
    """Limit this process for good (hard limits too) while it has one thread: namespaces
    are a thread's own, so they are made before the reply thread starts. Returns what the
    system granted."""
    applied = []
    memory = limits.memory_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    resource.setrlimit(resource.RLIMIT_CPU, (limits.cpu_seconds, limits.cpu_seconds + 2))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    applied += ["memory", "cpu", "no-file-writes"]
    with contextlib.suppress(OSError):
        os.nice(limits.nice)
    if syscalls.unshare(syscalls.CLONE_NEWNET):
        applied.append("no-network")
    if syscalls.unshare(syscalls.CLONE_NEWNS) and syscalls.read_only_mounts():
        applied.append("read-only-files")
    if os.geteuid() == 0:
        try:
            os.setgroups([])
            os.setgid(NOBODY)
            os.setuid(NOBODY)
            applied.append("unprivileged")
        except OSError:
            pass
    return applied


def close_off(syscall_filter: int | None) -> list[str]:
    """The last limits, once the reply thread runs: no process or thread may be started,
    no file or socket opened beyond the pipes held now, no privilege gained, and only the
    system calls a running program needs made (for every thread)."""
    resource.setrlimit(resource.RLIMIT_NPROC, (0, 0))
    highest = max(int(fd) for fd in os.listdir("/proc/self/fd"))
    resource.setrlimit(resource.RLIMIT_NOFILE, (highest + 1, highest + 1))
    applied = ["no-processes", "no-new-files"]
    if syscalls.no_new_privileges():
        applied.append("no-new-privileges")
    if syscalls.load(syscall_filter):
        applied.append("system-call-filter")
    return applied


class ProgramFinished(BaseException):
    """Raised by stop_program(); not an Exception, so `except Exception` lets it through."""


@dataclass
class Control:
    pause_requested: bool = False
    step_requested: bool = False
    paused: bool = False
    breakpoints: frozenset[str] = frozenset()
    cond: threading.Condition = field(default_factory=threading.Condition)


class Worker:
    """The host of the sandbox functions, on this side of the pipe."""

    def __init__(self, stdin: BinaryIO, stdout: BinaryIO) -> None:
        self.stdin = stdin
        self.stdout = stdout
        self.write_lock = threading.Lock()
        self.control = Control()
        self.block: str | None = None
        self._reported_block: str | None = None
        self._reported_at = 0.0
        self._calls: dict[int, tuple[threading.Event, list[dict[str, Any]]]] = {}
        self._next_call = 1
        self._output_window = (0.0, 0)
        self.started = time.monotonic()

    # Pipe ----------------------------------------------------------------------------------

    def send(self, message: dict[str, Any]) -> None:
        data = encode(message)
        with self.write_lock:
            self.stdout.write(data)
            self.stdout.flush()

    def read_start(self) -> dict[str, Any]:
        message = decode(self.stdin.readline())
        if message["t"] != "start":
            raise ProtocolError("the first message must be start")
        return message

    def serve_replies(self) -> None:
        """Reader thread: replies to calls and control from the runtime."""
        for line in iter(self.stdin.readline, b""):
            message = decode(line)
            kind = message["t"]
            if kind == "reply":
                slot = self._calls.get(int(message["id"]))
                if slot is not None:
                    slot[1].append(message)
                    slot[0].set()
            else:
                self._control(kind, message)
        os._exit(3)  # the runtime is gone: nothing to run for

    def _control(self, kind: str, message: dict[str, Any]) -> None:
        c = self.control
        with c.cond:
            if kind == "pause":
                c.pause_requested = True
            elif kind == "resume":
                c.pause_requested = c.step_requested = c.paused = False
            elif kind == "step":
                c.pause_requested, c.step_requested, c.paused = False, True, False
            elif kind == "breakpoints":
                c.breakpoints = frozenset(str(b) for b in message.get("ids", []))
            c.cond.notify_all()

    # Host ----------------------------------------------------------------------------------

    def call(self, fn: str, args: dict[str, Any]) -> Any:
        call_id = self._next_call
        self._next_call += 1
        event, box = threading.Event(), list[dict[str, Any]]()
        self._calls[call_id] = (event, box)
        try:
            self.send({"t": "call", "id": call_id, "fn": fn, "args": args, "block": self.block})
            event.wait()
        finally:
            del self._calls[call_id]
        reply = box[0]
        if reply.get("ok"):
            return reply.get("value")
        error = reply.get("error") or {}
        raise ProgramError(
            str(error.get("message", "failed")),
            str(error.get("code", "error")),
            error.get("words"),
        )

    def output(self, text: str, stream: str) -> None:
        start, count = self._output_window
        now = time.monotonic()
        if now - start >= 1.0:
            start, count = now, 0
        if count >= OUTPUT_PER_SECOND:
            time.sleep(max(0.0, start + 1.0 - now))
            start, count = time.monotonic(), 0
        self._output_window = (start, count + 1)
        if len(text) > MAX_OUTPUT_CHARS:
            text = text[:MAX_OUTPUT_CHARS] + f"… ({len(text) - MAX_OUTPUT_CHARS} more)"
        self.send({"t": "output", "text": text, "stream": stream, "block": self.block})

    def elapsed(self) -> float:
        return time.monotonic() - self.started

    def at_block(self, block_id: str) -> None:
        self.block = block_id
        c = self.control
        if c.pause_requested or c.step_requested or block_id in c.breakpoints:
            reason = (
                "breakpoint"
                if block_id in c.breakpoints
                else "step"
                if c.step_requested
                else "pause"
            )
            self._hold(reason, "")
            return
        now = time.monotonic()
        if block_id != self._reported_block and now - self._reported_at >= BLOCK_REPORT_INTERVAL:
            self._reported_block, self._reported_at = block_id, now
            self.send({"t": "block", "id": block_id})

    def _hold(self, reason: str, message: str) -> None:
        c = self.control
        with c.cond:
            c.pause_requested = c.step_requested = False
            c.paused = True
        self._reported_block = self.block
        self.send({"t": "paused", "block": self.block, "reason": reason, "message": message})
        with c.cond:
            while c.paused:
                c.cond.wait()
        self.send({"t": "resumed", "block": self.block})

    def sleep(self, seconds: float) -> None:
        remaining = seconds
        while remaining > 0:
            if self.control.pause_requested:
                self._hold("pause", "")
            chunk = min(SLEEP_SLICE, remaining)
            time.sleep(chunk)
            remaining -= chunk

    def confirm(self, message: str) -> None:
        self._hold("confirm", message[:MAX_OUTPUT_CHARS])

    def finish(self) -> None:
        raise ProgramFinished()

    def print_factory(self, _getattr: Any = None) -> Printer:
        return Printer(self)


class Printer:
    """RestrictedPython's print collector, sending each printed line to the runtime."""

    def __init__(self, worker: Worker) -> None:
        self.worker = worker

    def _call_print(self, *objects: Any, sep: Any = " ", end: Any = "\n", **_: Any) -> None:
        text = str(sep).join(str(o) for o in objects) + str(end)
        self.worker.output(text.removesuffix("\n"), "out")

    def __call__(self) -> str:
        return ""


def plugin_functions() -> dict[str, Any]:
    """The sandbox functions every plugin's blocks declare (the built-in blocks' are the
    library's own), imported before the program is read; one that cannot be imported is left
    out, and a program calling it fails with a NameError at its block. The runtime names
    them in the environment; a worker started without it reads the plugins itself."""
    named = os.environ.get(FUNCTIONS_ENV)
    if named is not None:
        references: dict[str, str] = json.loads(named)
    else:
        from openpendant.plugins.registry import registry

        references = {n: r for b in registry().blocks.values() for n, r in b.functions.items()}
    found: dict[str, Any] = {}
    for name, reference in references.items():
        module, _, attribute = reference.partition(":")
        try:
            found[name] = getattr(importlib.import_module(module), attribute)
        except Exception as exc:  # one plugin's fault is not the run's
            print(f"sandbox function {name} ({reference}) left out: {exc}", file=sys.stderr)
    return found


PLUGIN_FUNCTIONS = plugin_functions()


def program_globals(worker: Worker) -> dict[str, Any]:
    names: dict[str, Any] = {"__builtins__": safe_builtins(), "__name__": "program"}
    names.update(PLUGIN_FUNCTIONS)
    names.update(REGISTRY)  # the library's own names are never a plugin's to replace
    names.update(guard_globals())
    names["_print_"] = worker.print_factory
    return names


def error_line(exc: BaseException) -> int | None:
    line = None
    for frame, lineno in traceback.walk_tb(exc.__traceback__):
        if frame.f_code.co_filename == PROGRAM_FILENAME:
            line = lineno
    return line


def run(worker: Worker, start: dict[str, Any], isolation: list[str]) -> None:
    worker.control.breakpoints = frozenset(str(b) for b in start.get("breakpoints", []))
    try:
        compiled = compile_program(str(start.get("source", "")))
    except ProgramCompileError as exc:
        worker.send(
            {"t": "error", "kind": "compile", "message": str(exc), "line": exc.line, "block": None}
        )
        return
    worker.send({"t": "ready", "isolation": isolation})
    worker.started = time.monotonic()
    bind(worker)
    try:
        exec(compiled.code, program_globals(worker))
    except ProgramFinished:
        worker.send({"t": "done", "stopped": True})
        return
    except BaseException as exc:  # every error in a program is the program's error
        kind = type(exc).__name__
        message = str(exc) or kind
        # The runtime's own refusals read as they are ("the target … is out of reach");
        # a Python error keeps its name ("ZeroDivisionError: division by zero").
        shown = message if isinstance(exc, ProgramError) else f"{kind}: {message}"
        worker.send(
            {
                "t": "error",
                "kind": kind,
                "message": shown[:MAX_OUTPUT_CHARS],
                "line": error_line(exc),
                "block": worker.block,
                "code": getattr(exc, "code", None) if isinstance(exc, ProgramError) else None,
                "words": getattr(exc, "words", None) if isinstance(exc, ProgramError) else None,
            }
        )
        return
    worker.send({"t": "done", "stopped": False})


def main() -> None:
    limits = Limits.from_json(sys.argv[1] if len(sys.argv) > 1 else "{}")
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # nothing but protocol messages on the pipe
    isolation = isolate_process(limits)
    syscall_filter = syscalls.system_call_filter()
    worker = Worker(stdin, stdout)
    start = worker.read_start()
    threading.Thread(target=worker.serve_replies, daemon=True).start()
    try:
        run(worker, start, isolation + close_off(syscall_filter))
    except BaseException:  # our own failure: say so on stderr, never hang or abort
        traceback.print_exc()
        sys.stderr.flush()
        os._exit(4)
    sys.stderr.flush()
    os._exit(0)


if __name__ == "__main__":
    main()
