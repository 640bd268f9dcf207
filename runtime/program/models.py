"""What the program service stores and answers."""

from __future__ import annotations

import re
from typing import Any, Literal

from pydantic import BaseModel, Field

from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.kit.bodies import described_body
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.kit.words import Words, words

NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,63}\Z")
PREFIX = "program."
TAG = "program"


def check_program_name(name: str) -> str:
    if not NAME.match(name):
        raise InvalidValue(
            f"invalid program name {name[:80]!r}: start with a letter; letters, digits, "
            "'_' and '-' only; at most 64 characters",
            code="invalid_name",
            words=words("program.bad_name", name=name[:80]),
        )
    return name


class Program(BaseModel):
    name: str
    source: Literal["blocks", "python"]
    workspace: Any = None
    python: str
    version: int
    updated: float


class ProgramSummary(BaseModel):
    name: str
    source: str
    version: int
    updated: float


class ProblemInfo(BaseModel):
    """What keeps a program from running, at a block: an empty input, a loose block."""

    block: str
    message: str
    words: Words | None = None  # the message as a UI says it in its language


class Saved(BaseModel):
    name: str
    python: str
    version: int
    blocks: int
    problems: list[ProblemInfo] = Field(default_factory=list)  # saved, but it will not run


class ProgramImported(Saved):
    """A program file saved: for blocks, whether the Python generated here is the file's
    (another release may generate it otherwise; what runs is what was generated here)."""

    generated_as_in_file: bool | None = None


class RenameRequest(Strict):
    to: str = Field(min_length=1, max_length=64)


class RunRequest(Strict):
    breakpoints: list[str] = Field(default_factory=list, max_length=5000)
    # Control leases the caller already holds, by device: the program runs under them.
    leases: dict[str, str] = Field(default_factory=dict, max_length=16)
    robot: str | None = Field(default=None, max_length=32)  # the robot blocks start with
    time_limit: float | None = Field(default=None, gt=0, le=7 * 24 * 3600)


class BreakpointsRequest(Strict):
    ids: list[str] = Field(default_factory=list, max_length=5000)


class OutputEntry(BaseModel):
    seq: int
    text: str
    stream: str
    block: str | None
    ts: float
    words: Words | None = None  # an error line as a UI says it in its language


class ErrorInfo(BaseModel):
    message: str
    kind: str
    line: int | None = None
    block: str | None = None
    code: str | None = None
    words: Words | None = None  # the message as a UI says it in its language


class RunStatus(BaseModel):
    program: str
    run: int = 0  # which run of this program, since the service started (0: none yet)
    state: Literal["idle", "starting", "running", "paused", "stopped", "error", "finished"]
    block: str | None = None
    pause_reason: str = ""
    message: str = ""
    output: list[OutputEntry] = Field(default_factory=list)
    error: ErrorInfo | None = None
    robots: list[str] = Field(default_factory=list)  # the robots this run commanded
    isolation: list[str] = Field(default_factory=list)
    started: float | None = None
    ended: float | None = None
    stop_received: float | None = None  # when the stop reached the program service
    stop_request_start: float | None = None  # when it reached the webui (X-Request-Start)


class ProgramSource(BaseModel):
    """A program as a body says it: its blocks (Blockly's JSON) or its Python. Read by the
    service itself (bounded in size and depth before it is parsed), described here."""

    workspace: dict[str, Any] | None = None
    python: str | None = None


class Generated(BaseModel):
    """The Python of a workspace, as saving it would give; nothing kept."""

    python: str
    blocks: int
    problems: list[ProblemInfo]


class BlockCatalog(BaseModel):
    """Block definitions by category and the toolbox, for the editor (Blockly's JSON)."""

    definitions: dict[str, list[dict[str, Any]]]
    toolbox: dict[str, Any]
    # The blocks' translations: per language, block words by type, and the plugins'
    # category names by their English name.
    words: dict[str, dict[str, Any]]


# The body of PUT /programs/{name} and POST /programs/_generate, for the API's document.
SOURCE_BODY = described_body("application/json", ProgramSource.model_json_schema())
