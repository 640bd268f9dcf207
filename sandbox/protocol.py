"""The worker's pipe protocol: one JSON object per line, each with a type `t`.

runtime → worker: start {source, breakpoints, limits}, reply {id, ok, value | error},
pause, resume, step, breakpoints {ids}.
worker → runtime: ready {isolation}, block {id}, paused {block, reason, message}, resumed,
call {id, fn, args, block}, output {text, stream, block}, error {message, kind, line,
block}, done {stopped}."""

from __future__ import annotations

import json
from typing import Any

MAX_LINE_BYTES = 2 * 1024 * 1024
MAX_OUTPUT_CHARS = 2000  # one printed line, as it reaches the output console
# Every limit a worker takes where the system grants it, as its `ready` names them.
ISOLATION = (
    "memory",
    "cpu",
    "no-file-writes",
    "no-network",
    "read-only-files",
    "unprivileged",
    "no-processes",
    "no-new-files",
    "no-new-privileges",
    "system-call-filter",
)
# The worker's environment names the plugins' sandbox functions: {name: "module:attribute"}.
FUNCTIONS_ENV = "OPENPENDANT_SANDBOX_FUNCTIONS"


class ProtocolError(Exception):
    pass


def encode(message: dict[str, Any]) -> bytes:
    data = json.dumps(message, allow_nan=False, separators=(",", ":")).encode() + b"\n"
    if len(data) > MAX_LINE_BYTES:
        raise ProtocolError(f"a message of {len(data)} bytes is over the {MAX_LINE_BYTES} limit")
    return data


def decode(line: bytes) -> dict[str, Any]:
    try:
        message = json.loads(line, parse_constant=_refuse_constant)
    except (ValueError, RecursionError) as exc:
        raise ProtocolError(f"not a protocol message: {exc}") from exc
    if not isinstance(message, dict) or not isinstance(message.get("t"), str):
        raise ProtocolError("a protocol message is an object with a type")
    return message


def _refuse_constant(name: str) -> float:
    raise ValueError(f"{name} is not allowed")
