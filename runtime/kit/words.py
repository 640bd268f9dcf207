"""Server texts a UI can say in its own language: beside the English message (kept for API
users and logs), a stable code and the values it names. The UI words a code it knows from its
catalogue (`server.<code>` in webui/frontend/src/i18n/en.ts and de.ts) and shows the English
for one it does not.

CODES is every code a service, the gateway or a program run can send, with the names of its
params; tests hold each catalogue to it. A param is text, a number, or words of its own (a
role, an input's name), which the UI words in turn."""

from __future__ import annotations

import math
import re
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

CODES: dict[str, tuple[str, ...]] = {
    # Words used inside others
    "role.viewer": (),
    "role.operator": (),
    "role.programmer": (),
    "role.admin": (),
    # Access (webui/access.py)
    "access.sign_in": (),
    "access.role": ("role", "need"),
    "access.csrf": (),
    "access.session_ended": ("why",),
    "session.expired": (),
    "session.signed_out": (),
    "session.role_changed": (),
    "session.password_changed": (),
    "session.user_removed": (),
    "session.secure_connection": (),
    # Links and control of a device
    "link.stale": ("device",),
    "link.changed": ("device",),
    "link.manager_down": (),
    "device.disconnected": ("device",),
    "lease.required": ("device",),
    "lease.held": ("device", "holder"),
    # A robot refusing a command
    "robot.not_enabled": (),
    "robot.estop": (),
    "robot.fault": ("error",),
    "robot.reset_first": (),
    "robot.not_manual": (),
    "robot.wrong_mode": ("needed", "mode"),
    "robot.position_limit": ("joint",),
    # Planning a move
    "motion.unreachable": (),
    "motion.out_of_reach": ("where",),
    "motion.leaves_workspace": ("where",),
    "motion.singularity": ("where",),
    "motion.collision": ("part", "other"),
    "motion.collision_now": ("part", "other"),
    "motion.collision_at_target": ("part", "other"),
    "motion.busy": ("robot",),
    # Jogging
    "jog.held_near": ("part", "distance", "other", "clear"),
    "jog.held_limit": (),
    "jog.deadman": ("ms",),
    # A program's stored values
    "storage.reserved": ("name", "prefix"),
    "storage.users": ("name",),
    "storage.full": ("program", "bytes", "budget"),
    "storage.too_large": ("name", "size", "limit"),
    "storage.bad_name": ("name",),
    # A program's check before it runs (blockly_blocks, runtime/program/compiler.py)
    "program.input_empty": ("block", "input"),
    "program.loose": ("block",),
    "program.input.condition": (),
    "program.input.times": (),
    "program.input.target": (),
    "program.input.list": (),
    "program.input.text": (),
    "program.input.value": (),
    "program.input.number": (),
    "program.input.start": (),
    "program.input.end": (),
    "program.input.step": (),
    "program.input.named": ("name",),
    "program.unreadable": ("reason",),  # any other fault of a workspace's JSON
    "program.unknown_block": ("type",),
    "program.unknown_variable": ("block",),
    "program.not_a_value": ("type",),
    "program.not_a_statement": ("type",),
    "program.two_functions": ("name",),
    "program.no_function": ("name",),
    "program.return_outside": (),
    "program.nothing_chosen": ("block",),
    "program.policy": ("errors",),
    "program.too_complex": (),
    "program.has_problems": ("program", "problem"),
    "program.has_problems_more": ("program", "problem", "more"),
    "program.bad_name": ("name",),
    "program.busy": ("program",),
    "program.too_many_runs": ("count",),
    # A run's errors (sandbox/supervisor.py, runtime/program/host.py)
    "run.stopped": (),
    "run.timeout": ("seconds",),
    "run.cpu_limit": ("seconds",),
    "run.killed": ("signal",),
    "run.worker_ended": ("exit", "detail"),
    "run.protocol": ("reason",),
    "run.exception": ("error",),
    "run.compile": ("error",),
    "run.at_line": ("message", "line"),
    "run.no_robot": (),
    "run.no_waypoint": ("name",),
    "run.unknown_function": ("name",),
    "run.function_failed": ("name", "error"),
    "run.crashed": (),
}

CODE = re.compile(r"^[a-z][a-z0-9_]*(\.[a-z0-9_]+)+\Z")
MAX_TEXT = 500  # characters of a text param taken from elsewhere
MAX_PARAMS = 8
MAX_DEPTH = 3


class Words(BaseModel):
    """A text as its code and params; `params` holds nested words as their bodies."""

    model_config = ConfigDict(frozen=True)

    code: str
    params: dict[str, Any] = Field(default_factory=dict)

    def body(self) -> dict[str, Any]:
        return self.model_dump()


Param = str | int | float | Words


def words(code: str, **params: Param) -> Words:
    return Words(
        code=code,
        params={k: v.body() if isinstance(v, Words) else v for k, v in params.items()},
    )


def role_words(role: str) -> Words:
    return words(f"role.{role}")


def link_words(device: str, status: str) -> Words:
    """Why a device's link takes no command: stale, or not connected."""
    return words("link.stale" if status == "stale" else "device.disconnected", device=device)


def words_of(value: Any, depth: int = 0) -> Words | None:
    """Words received from another process (a service, a program's worker): only the shape
    the UI reads, anything else dropped. A code need not be known here: the UI then shows
    the English."""
    if isinstance(value, Words):
        return value
    if not isinstance(value, dict) or depth > MAX_DEPTH:
        return None
    code, raw = value.get("code"), value.get("params", {})
    if not isinstance(code, str) or not CODE.match(code) or len(code) > 80:
        return None
    if not isinstance(raw, dict) or len(raw) > MAX_PARAMS:
        return None
    params: dict[str, Any] = {}
    for name, param in raw.items():
        if not isinstance(name, str) or not name.isidentifier():
            return None
        if isinstance(param, bool) or param is None:
            return None
        if isinstance(param, str):
            params[name] = param[:MAX_TEXT]
        elif isinstance(param, int | float):
            if not math.isfinite(param):
                return None
            params[name] = param
        else:
            nested = words_of(param, depth + 1)
            if nested is None:
                return None
            params[name] = nested.body()
    return Words(code=code, params=params)
