"""A Blockly workspace (JSON serialization, `Blockly.serialization.workspaces.save`) read into
blocks, with every way it can be malformed refused by a clear WorkspaceError: not JSON, too
large or too deeply nested, unknown block types, missing or wrong fields, a block id used
twice."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from typing import Any

from openpendant.runtime.kit.words import Words, words

MAX_WORKSPACE_BYTES = 4 * 1024 * 1024
MAX_BLOCKS = 5000
MAX_NESTING = 60  # blocks inside blocks (value inputs and statement bodies)
MAX_TEXT = 10_000
MAX_ID = 64
# A stack of N statements is N levels of "next" in the JSON; the C parser needs the
# recursion limit above the JSON depth to read long stacks.
JSON_RECURSION_LIMIT = 4 * MAX_BLOCKS + 1000


class WorkspaceError(Exception):
    """Why a workspace gives no program; `said`, the words a UI shows in its language (those
    of the faults a user of the editor can meet: the rest are the JSON's)."""

    def __init__(self, message: str, block: str | None = None, said: Words | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.block = block
        self.words = said


@dataclass
class Block:
    type: str
    id: str
    fields: dict[str, Any] = field(default_factory=dict)
    inputs: dict[str, Block] = field(default_factory=dict)
    next: Block | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    x: float = 0.0
    y: float = 0.0

    def field(self, name: str) -> Any:
        if name not in self.fields:
            raise WorkspaceError(f"block {self.type} lacks its {name} field", self.id)
        return self.fields[name]


@dataclass
class Workspace:
    top: list[Block]
    variables: dict[str, str]  # id -> name
    count: int


def allow_deep_json() -> None:
    """Let this process read and write workspaces with long stacks."""
    if sys.getrecursionlimit() < JSON_RECURSION_LIMIT:
        sys.setrecursionlimit(JSON_RECURSION_LIMIT)


def parse_json(raw: bytes | str) -> Any:
    if len(raw) > MAX_WORKSPACE_BYTES:
        raise WorkspaceError(f"the workspace is larger than {MAX_WORKSPACE_BYTES} bytes")
    allow_deep_json()
    try:
        return json.loads(raw, parse_constant=_no_constant)
    except RecursionError:
        raise WorkspaceError("the workspace is nested too deeply") from None
    except ValueError as exc:
        raise WorkspaceError(f"the workspace is not JSON: {exc}") from None


def dump_json(data: Any) -> str:
    allow_deep_json()
    try:
        return json.dumps(data, separators=(",", ":"), allow_nan=False)
    except RecursionError:
        raise WorkspaceError("the workspace is nested too deeply") from None
    except ValueError as exc:
        raise WorkspaceError(f"the workspace is not JSON: {exc}") from None


class Reader:
    def __init__(self, known_types: frozenset[str]) -> None:
        self.known = known_types
        self.ids: set[str] = set()

    def workspace(self, data: Any) -> Workspace:
        if not isinstance(data, dict):
            raise WorkspaceError("a workspace is a JSON object")
        blocks = data.get("blocks", {})
        if not isinstance(blocks, dict):
            raise WorkspaceError('"blocks" must be an object')
        top_raw = blocks.get("blocks", [])
        if not isinstance(top_raw, list):
            raise WorkspaceError('"blocks.blocks" must be a list')
        variables = self._variables(data.get("variables", []))
        top = [self.block(raw, 0) for raw in top_raw]
        return Workspace(top, variables, len(self.ids))

    def _variables(self, raw: Any) -> dict[str, str]:
        if not isinstance(raw, list):
            raise WorkspaceError('"variables" must be a list')
        found: dict[str, str] = {}
        for item in raw:
            if not isinstance(item, dict):
                raise WorkspaceError("a variable is an object with a name and an id")
            name, var_id = item.get("name"), item.get("id")
            if not (isinstance(name, str) and isinstance(var_id, str)):
                raise WorkspaceError("a variable needs a name and an id")
            if not _short_text(name, MAX_TEXT) or not _short_text(var_id, MAX_ID):
                raise WorkspaceError("a variable needs a name and an id")
            found[var_id] = name
        return found

    def block(self, raw: Any, depth: int) -> Block:
        """One block and the stack under it (iteratively: stacks may be long)."""
        first: Block | None = None
        previous: Block | None = None
        while raw is not None:
            block = self._one(raw, depth)
            if previous is None:
                first = block
            else:
                previous.next = block
            previous = block
            raw = self._connection(raw.get("next"), "next", block.id)
        assert first is not None
        return first

    def _one(self, raw: Any, depth: int) -> Block:
        if depth > MAX_NESTING:
            raise WorkspaceError(f"blocks are nested more than {MAX_NESTING} deep")
        if not isinstance(raw, dict):
            raise WorkspaceError("a block is a JSON object")
        block_id, kind = raw.get("id"), raw.get("type")
        if not isinstance(block_id, str) or not _short_text(block_id, MAX_ID):
            raise WorkspaceError("every block needs an id (text, at most 64 characters)")
        if not isinstance(kind, str):
            raise WorkspaceError("a block has no type", block_id)
        if kind not in self.known:
            raise WorkspaceError(
                f"unknown block type {kind[:64]!r}",
                block_id,
                words("program.unknown_block", type=kind[:64]),
            )
        if block_id in self.ids:
            raise WorkspaceError(f"block id {block_id!r} is used twice", block_id)
        self.ids.add(block_id)
        if len(self.ids) > MAX_BLOCKS:
            raise WorkspaceError(f"the workspace has more than {MAX_BLOCKS} blocks")
        fields = raw.get("fields", {})
        extra = raw.get("extraState", {})
        if not isinstance(fields, dict) or not isinstance(extra, dict | str):
            raise WorkspaceError(f"block {kind} has malformed fields", block_id)
        for name, value in fields.items():
            if not _field_value(value):
                raise WorkspaceError(f"block {kind} has a malformed {name} field", block_id)
        inputs: dict[str, Block] = {}
        raw_inputs = raw.get("inputs", {})
        if not isinstance(raw_inputs, dict):
            raise WorkspaceError(f"block {kind} has malformed inputs", block_id)
        for name, connection in raw_inputs.items():
            child = self._connection(connection, name, block_id)
            if child is not None:
                inputs[str(name)] = self.block(child, depth + 1)
        return Block(
            type=kind,
            id=block_id,
            fields=fields,
            inputs=inputs,
            extra=extra if isinstance(extra, dict) else {},
            x=_number(raw.get("x")),
            y=_number(raw.get("y")),
        )

    def _connection(self, connection: Any, name: str, block_id: str) -> Any:
        """The block plugged into a connection: the real one, else its shadow."""
        if connection is None:
            return None
        if not isinstance(connection, dict):
            raise WorkspaceError(f"input {name} is malformed", block_id)
        child = connection.get("block") or connection.get("shadow")
        if child is not None and not isinstance(child, dict):
            raise WorkspaceError(f"input {name} is malformed", block_id)
        return child


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number a workspace may hold")


def _short_text(value: Any, limit: int) -> bool:
    return isinstance(value, str) and 0 < len(value) <= limit


def _field_value(value: Any) -> bool:
    if isinstance(value, str):
        return len(value) <= MAX_TEXT
    if isinstance(value, bool) or value is None:
        return True
    if isinstance(value, int | float):
        return value == value and abs(value) != float("inf")
    if isinstance(value, dict):  # a variable field: {"id": ...}
        return _short_text(value.get("id"), MAX_ID)
    return False


def _number(value: Any) -> float:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else 0.0
