"""A program as a file, for version control and for moving it between cells: one JSON
document with its Blockly workspace (or its hand-written Python) and the Python this runtime
generated from it, one line an item so that a diff shows what changed line by line. The
workspace is written on one line: Blockly nests a stack of blocks one level a block, and
indented it would grow with the square of the stack's length.

An imported file is checked as a save is: its blocks are generated and compiled again, and
that Python is what runs; the file's own Python is compared with it, never run."""

from __future__ import annotations

import json
import uuid
from typing import Any, Literal

from pydantic import Field, ValidationError

from openpendant.blockly_blocks.workspace import MAX_WORKSPACE_BYTES, allow_deep_json
from openpendant.runtime import __version__
from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.kit.bodies import described_body
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.program.models import Program

FORMAT = "openpendant-program"
# Its workspace at most a save's size (4 MiB), with the lines of its Python beside it.
MAX_FILE_BYTES = 2 * MAX_WORKSPACE_BYTES
SUFFIX = ".openpendant.json"


class ProgramFile(Strict):
    format: Literal["openpendant-program"]
    version: Literal[1]
    name: str = Field(max_length=64)  # the program's name where it was exported
    exported_by: str = Field(default="", max_length=64)  # the runtime's version
    source: Literal["blocks", "python"]
    workspace: Any = None  # blocks: Blockly's JSON serialization of the workspace
    # blocks: the Python generated from them (compared on import, never run); python: the
    # program itself.
    python: list[str] = Field(max_length=200_000)


def file_bytes(program: Program) -> bytes:
    document = ProgramFile(
        format=FORMAT,
        version=1,
        name=program.name,
        exported_by=__version__,
        source=program.source,
        workspace=None,
        python=program.python.split("\n"),
    ).model_dump()
    placeholder = uuid.uuid4().hex
    if program.source == "blocks":
        document["workspace"] = placeholder
    text = json.dumps(document, indent=2, ensure_ascii=False) + "\n"
    if program.source == "blocks":
        allow_deep_json()  # a long stack of blocks nests deeply
        compact = json.dumps(program.workspace, separators=(",", ":"), ensure_ascii=False)
        text = text.replace(json.dumps(placeholder), compact, 1)
    return text.encode()


def read_file(body: bytes) -> ProgramFile:
    """A file's document, or an InvalidValue saying what is wrong with it."""
    if len(body) > MAX_FILE_BYTES:
        raise InvalidValue(f"the file is larger than {MAX_FILE_BYTES} bytes", code="invalid_file")
    allow_deep_json()  # a long stack of blocks nests deeply
    try:
        data = json.loads(body, parse_constant=_no_constant)
    except RecursionError:
        raise InvalidValue("the file is nested too deeply", code="invalid_file") from None
    except ValueError as exc:
        raise InvalidValue(f"not a program file: {exc}", code="invalid_file") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InvalidValue(
            f'not a program file: it has no "format": "{FORMAT}" (export one from the Program '
            "panel or GET /api/programs/NAME/file)",
            code="invalid_file",
        )
    try:
        document = ProgramFile.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise InvalidValue(
            f"not a program file: {where}: {first['msg']}", code="invalid_file"
        ) from None
    if document.source == "blocks" and document.workspace is None:
        raise InvalidValue("not a program file: its blocks are missing", code="invalid_file")
    return document


def _no_constant(name: str) -> None:
    raise ValueError(f"{name} is not a number JSON allows")


def save_body(document: ProgramFile) -> bytes:
    """What a save of the file's program sends (the checks are the save's)."""
    allow_deep_json()
    if document.source == "blocks":
        return json.dumps({"workspace": document.workspace}).encode()
    return json.dumps({"python": "\n".join(document.python)}).encode()


# Read by the service itself (bounded in size and depth before it is parsed), described here.
FILE_BODY = described_body("application/json", ProgramFile.model_json_schema())
