"""Who may call what: the one table of the runtime's rights, by method and path below /api.

Reading is a viewer's right; changing needs the role the table gives. Stopping is every
signed-in user's right (a viewer who sees something go wrong must be able to stop it). A
route the table does not name is an administrator's only."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

from openpendant.runtime.auth.roles import Role

PUBLIC: Literal["public"] = "public"
INTERNAL: Literal["internal"] = "internal"
Need = Role | Literal["public", "internal"]

VIEW, OPERATE, PROGRAM, ADMIN = Role.viewer, Role.operator, Role.programmer, Role.admin
READ = ("GET", "HEAD")
WRITE = ("POST", "PUT", "PATCH", "DELETE")
SOCKET = ("WS",)
ANY = (*READ, *WRITE)
SEG = r"[^/]+"


@dataclass(frozen=True)
class Rule:
    methods: tuple[str, ...]
    pattern: re.Pattern[str]
    need: Need


def rule(methods: tuple[str, ...], path: str, need: Need) -> Rule:
    return Rule(methods, re.compile(f"^{path.replace('{}', SEG)}\\Z"), need)


RULES: tuple[Rule, ...] = (
    # Signing in, and what the sign-in screen needs before it.
    rule(READ, "/auth/status", PUBLIC),
    rule(("POST",), "/auth/(login|setup|pin)", PUBLIC),
    rule(("POST",), "/auth/logout", VIEW),
    rule(READ, "/auth/me", VIEW),
    rule(READ, "/auth/policy", VIEW),
    rule(("POST",), "/auth/me/password", VIEW),
    rule(("POST",), "/auth/ticket", OPERATE),
    rule(ANY, "/auth/(users|tokens)(/{})?", ADMIN),
    rule(READ, "/auth/audit(/export)?", ADMIN),
    # Stop always wins: every signed-in user may stop.
    rule(("POST",), "/devices/_stop", VIEW),
    rule(("POST",), "/programs/_stop", VIEW),
    rule(("POST",), "/programs/{}/stop", VIEW),
    rule(("POST",), "/jog/robots/{}/halt", VIEW),
    rule(("POST",), "/motion/robots/{}/stop", VIEW),
    rule(("POST",), "/motion/moves/{}/cancel", VIEW),
    rule(SOCKET, "/programs/_ws", VIEW),
    rule(SOCKET, "/devices/ws", VIEW),
    rule(SOCKET, "/devices/{}/frames/ws", VIEW),
    rule(SOCKET, "/variables/_events", VIEW),
    # Services' own link socket: never through the gateway.
    rule((*SOCKET, *ANY), "/devices/_links", INTERNAL),
    # Devices: adding, moving and removing them is an administrator's; control is an
    # operator's; a tool's set-up a programmer's.
    rule(("POST",), "/devices", ADMIN),
    rule(("PUT",), "/devices/{}/address", ADMIN),
    rule(("DELETE",), "/devices/{}", ADMIN),
    rule(("POST", "DELETE"), "/devices/{}/lease", OPERATE),
    rule(("POST",), "/devices/{}/lease/check", OPERATE),
    rule(("POST",), "/devices/{}/call/{}", OPERATE),
    rule(("PUT",), "/devices/{}/tool", PROGRAM),
    rule(READ, "/devices/{}/cell/parts", VIEW),
    # Jogging and teaching.
    rule(SOCKET, "/jog/ws", OPERATE),
    rule(("POST",), "/jog/robots/{}/(enable|disable|reset_errors)", OPERATE),
    rule(("PUT",), "/jog/robots/{}/speed", OPERATE),
    rule(("POST",), "/jog/robots/{}/teach", PROGRAM),
    # Moves.
    rule(("POST",), "/motion/robots/{}/(plan|moves|pause|resume)", OPERATE),
    # Vision: calibrating a camera (or placing it in the world) is a programmer's, as
    # changing a frame is; stopping an operation is everyone's.
    rule(("POST",), "/vision/operations/{}/cancel", VIEW),
    rule(("POST",), "/vision/(intrinsic|extrinsic|robot_origin)", PROGRAM),
    rule(("POST",), "/vision/intrinsic/{}/(capture|solve)", PROGRAM),
    rule(("DELETE",), "/vision/intrinsic/{}/frames/{}", PROGRAM),
    rule(("POST",), "/vision/operations/{}/save", PROGRAM),
    rule(("POST",), "/vision/detectors/{}/detect", OPERATE),
    rule(("PUT",), "/vision/detectors/{}/template", PROGRAM),
    rule(("PUT",), "/vision/cameras/{}/calibration.yaml", PROGRAM),
    # A network runs in OpenCV's parser: installing one is an administrator's.
    rule(("PUT", "DELETE"), "/vision/models/{}", ADMIN),
    # Programs: running them is an operator's, editing them a programmer's.
    rule(("POST",), "/programs/{}/(run|pause|resume|step)", OPERATE),
    rule(("PUT",), "/programs/{}/breakpoints", OPERATE),
    rule(("POST",), "/programs/_generate", PROGRAM),
    rule(("PUT", "DELETE"), "/programs/{}", PROGRAM),
    rule(("PUT",), "/programs/{}/file", PROGRAM),
    rule(("POST",), "/programs/{}/(rename|duplicate)", PROGRAM),
    # Variables: waypoints, frames, the scene, calibrations.
    rule(("POST",), "/variables/_import", ADMIN),
    rule(("PUT", "DELETE"), "/variables/{}", PROGRAM),
    rule(("POST",), "/variables/{}/rename", PROGRAM),
    # The gateway's own.
    rule(READ, "/logs", PROGRAM),
    # Everything else may be read by anyone signed in.
    rule(READ, "/.*", VIEW),
)


def need(method: str, path: str) -> Need:
    """The right a request needs; `path` is below /api (it starts with a slash)."""
    for entry in RULES:
        if method in entry.methods and entry.pattern.match(path):
            return entry.need
    return ADMIN


def served() -> list[dict[str, object]]:
    """The table as the UI evaluates it (GET /api/auth/policy), in order: each rule's methods,
    its pattern as JavaScript's RegExp reads it the same (`$` there is the end of the text,
    as `\\Z` is here) and the role it needs by name. A request no rule names is an
    administrator's."""
    return [
        {
            "methods": list(entry.methods),
            "pattern": entry.pattern.pattern.removesuffix("\\Z") + "$",
            "need": entry.need.name if isinstance(entry.need, Role) else entry.need,
        }
        for entry in RULES
    ]


def named(method: str, path: str) -> bool:
    """Whether the table names the request other than by its catch-alls (tests check every
    route is named)."""
    return any(method in e.methods and e.pattern.match(path) for e in RULES[:-1])
