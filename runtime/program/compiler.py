"""Reading, generating and compiling programs in a process of their own.

The program service's event loop carries the pendant's Stop. A 4 MB workspace takes seconds
to parse, generate and compile; in a thread of this process it would still hold the
interpreter's lock most of that time and slow every step of a stop. In a child process it
costs the loop nothing. The child is forked when the service starts, so it shares the
already-imported generator and policy instead of loading its own copy; it works on one
request at a time and is replaced if it dies or runs over its time."""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import ctypes
import logging
import multiprocessing
import os
import signal
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from openpendant.blockly_blocks.generate import generate
from openpendant.blockly_blocks.generator import Generated
from openpendant.blockly_blocks.workspace import (
    WorkspaceError,
    allow_deep_json,
    dump_json,
    parse_json,
)
from openpendant.runtime.interfaces.variables import StoredProgram
from openpendant.runtime.kit.errors import InvalidValue, OpenPendantError
from openpendant.runtime.kit.words import words
from openpendant.runtime.program.models import ProblemInfo
from openpendant.sandbox.policy import ProgramCompileError, compile_program

log = logging.getLogger(__name__)

T = TypeVar("T")

# A 5,000-block workspace generates and compiles in a few seconds here; far beyond that the
# request is not worth the CPU (and a stuck child is replaced).
TIME_LIMIT = 60.0


def workspace_error(exc: WorkspaceError) -> InvalidValue:
    details = {"block": exc.block} if exc.block else None
    said = exc.words or words("program.unreadable", reason=exc.message)
    return InvalidValue(exc.message, code="invalid_workspace", details=details, words=said)


def compile_error(exc: ProgramCompileError) -> InvalidValue:
    return InvalidValue(
        f"the program breaks the sandbox policy: {exc}",
        code="invalid_program",
        details={"errors": exc.errors, "line": exc.line},
        words=words("program.policy", errors=str(exc)),
    )


def problem_infos(generated: Generated) -> list[ProblemInfo]:
    return [
        ProblemInfo(block=p.block, message=p.message, words=p.words) for p in generated.problems
    ]


def read_request(body: bytes) -> dict[str, Any]:
    """A save or preview body: {"workspace": <Blockly JSON>} or {"python": "<code>"}."""
    try:
        data = parse_json(body)
    except WorkspaceError as exc:
        raise workspace_error(exc) from None
    if not isinstance(data, dict) or ("workspace" in data) == ("python" in data):
        raise InvalidValue('send {"workspace": <Blockly JSON>} or {"python": "<code>"}')
    return data


def workspace_text(data: dict[str, Any]) -> str:
    try:
        return dump_json(data["workspace"])
    except WorkspaceError as exc:
        raise workspace_error(exc) from None


def generate_checked(raw: bytes | str) -> Generated:
    """Parse, generate and compile a workspace; any problem is an InvalidValue."""
    try:
        generated = generate(raw)
        compile_program(generated.python)
    except WorkspaceError as exc:
        raise workspace_error(exc) from None
    except ProgramCompileError as exc:
        raise compile_error(exc) from None
    return generated


@dataclass(frozen=True)
class Prepared:
    """What a save keeps, and what its answer shows."""

    stored: dict[str, Any]
    python: str
    blocks: int
    problems: list[ProblemInfo]


def prepare_save(body: bytes) -> Prepared:
    """Body: {"workspace": <Blockly JSON>} or {"python": "<code>"}, checked through."""
    data = read_request(body)
    if "python" in data:
        python = data["python"]
        if not isinstance(python, str):
            raise InvalidValue("python must be text")
        try:
            compile_program(python)
        except ProgramCompileError as exc:
            raise compile_error(exc) from None
        stored = StoredProgram(source="python", python=python)
        return Prepared(stored.model_dump(), python, 0, [])
    workspace_json = workspace_text(data)
    generated = generate_checked(workspace_json)
    stored = StoredProgram(source="blocks", workspace_json=workspace_json, python=generated.python)
    return Prepared(
        stored.model_dump(), generated.python, generated.blocks, problem_infos(generated)
    )


def preview(body: bytes) -> Generated:
    """The Python of {"workspace": <Blockly JSON>}, as saving it would give."""
    data = read_request(body)
    if "workspace" not in data:
        raise InvalidValue('send {"workspace": <Blockly JSON>}')
    return generate_checked(workspace_text(data))


def problems_of(workspace_json: str) -> list[ProblemInfo]:
    return problem_infos(generate_checked(workspace_json))


def _answer(fn: Callable[..., T], *args: Any) -> tuple[bool, Any]:
    """Runs in the child: a domain error travels back as its body, not as a pickled class."""
    try:
        return True, fn(*args)
    except OpenPendantError as exc:
        return False, (exc.status, exc.body())


def _ready() -> bool:
    return True


PR_SET_PDEATHSIG = 1


def _child_start(parent: int) -> None:
    """In the child: it dies with the program service. A `kill -9` of the service must not
    leave a compiler behind (it would wait on its queue, holding memory, for ever)."""
    libc = ctypes.CDLL("libc.so.6", use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent:  # the service died before the line above
        os._exit(0)
    allow_deep_json()


class Compiler:
    def __init__(self, time_limit: float = TIME_LIMIT) -> None:
        self.time_limit = time_limit
        self._pool: concurrent.futures.ProcessPoolExecutor | None = None
        self._lock = asyncio.Lock()

    async def start(self) -> None:
        """Forks the child now, while the service has no other threads."""
        await self._run(_ready)

    def _executor(self) -> concurrent.futures.ProcessPoolExecutor:
        if self._pool is None:
            self._pool = concurrent.futures.ProcessPoolExecutor(
                max_workers=1,
                mp_context=multiprocessing.get_context("fork"),
                initializer=_child_start,
                initargs=(os.getpid(),),
            )
        return self._pool

    async def _run(self, fn: Callable[..., T], *args: Any) -> T:
        async with self._lock:
            future = asyncio.get_running_loop().run_in_executor(
                self._executor(), _answer, fn, *args
            )
            try:
                ok, value = await asyncio.wait_for(future, self.time_limit)
            except TimeoutError:
                self._replace("ran over its time")
                raise InvalidValue(
                    f"the program took longer than {self.time_limit:.0f} s to check; make it "
                    "smaller",
                    code="too_complex",
                    words=words("program.too_complex"),
                ) from None
            except concurrent.futures.process.BrokenProcessPool:
                self._replace("died")
                raise InvalidValue(
                    "checking the program took more than its process could give; make it smaller",
                    code="too_complex",
                    words=words("program.too_complex"),
                ) from None
        if not ok:
            status, body = value
            raise OpenPendantError.from_body(status, body)
        return value  # type: ignore[no-any-return]

    def _replace(self, why: str) -> None:
        log.warning("the program compiler %s; a new one is started", why)
        pool, self._pool = self._pool, None
        if pool is not None:
            for process in list(getattr(pool, "_processes", {}).values()):
                with contextlib.suppress(ProcessLookupError, AttributeError):
                    process.kill()
            pool.shutdown(wait=False, cancel_futures=True)

    async def prepare_save(self, body: bytes) -> Prepared:
        return await self._run(prepare_save, body)

    async def preview(self, body: bytes) -> Generated:
        return await self._run(preview, body)

    async def problems(self, workspace_json: str) -> list[ProblemInfo]:
        return await self._run(problems_of, workspace_json)

    async def close(self) -> None:
        pool, self._pool = self._pool, None
        if pool is not None:
            await asyncio.to_thread(pool.shutdown, wait=True, cancel_futures=True)
