"""Calls of a device's interface methods through the device manager, for the UI and scripts:
`POST /devices/{name}/call/{method}` with `{"args": [path parameters], "body": {…}}`. Only
what the device's kind declares with `@endpoint` can be called, its body checked first; a
command needs the device's control lease, but for `stop`, which anyone may send. Robots are
not moved this way: their motion goes through jog (hold-to-run) and motion (planned,
checked moves)."""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from pydantic import Field, ValidationError

from openpendant.plugins.api import DeviceKind, resolve
from openpendant.plugins.registry import registry as plugins
from openpendant.runtime.device_manager.registry import DeviceRegistry
from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.interfaces.endpoints import Endpoint, endpoints
from openpendant.runtime.kit.app import describe_validation_errors
from openpendant.runtime.kit.errors import Conflict, InvalidValue, NotFound, Unavailable

log = logging.getLogger(__name__)

# Stop always wins: anyone may stop a device, control or not.
ANYONE = ("stop",)


class CallRequest(Strict):
    args: list[str | int] = Field(default_factory=list, max_length=8)
    body: dict[str, Any] | None = None


def declared(kind: DeviceKind) -> dict[str, Endpoint]:
    """The methods a kind's interface declares; a plugin that cannot load has none to call."""
    try:
        return endpoints(resolve(kind.interface))
    except Exception as exc:
        raise Unavailable(
            f"the {kind.name} interface cannot be loaded: {exc}", code="plugin_failed"
        ) from exc


async def call_device(
    devices: DeviceRegistry,
    local_name: str,
    method: str,
    request: CallRequest,
    token: str | None,
) -> tuple[int, Any]:
    """The driver's answer: (HTTP status, JSON body)."""
    conn = devices.connection(local_name)
    kind = plugins().kinds.get(conn.record.kind)
    if kind is None:
        raise NotFound(f"no installed plugin knows {conn.record.kind!r}", code="unknown_kind")
    if kind.session:
        raise Conflict(
            f"{local_name} is moved through jogging and planned moves, not by calls",
            code="not_callable",
        )
    ep = declared(kind).get(method)
    if ep is None:
        raise NotFound(f"a {kind.name} has no method {method[:40]!r}", code="unknown_method")
    if len(request.args) != len(ep.params):
        raise InvalidValue(f"{method} takes {len(ep.params)} arguments ({', '.join(ep.params)})")
    payload = None
    if ep.body is not None:
        try:
            payload = ep.body.model_validate(request.body or {}).model_dump(mode="json")
        except ValidationError as exc:
            message, _ = describe_validation_errors(exc.errors())
            raise InvalidValue(message, code="invalid_request") from exc
    elif request.body:
        raise InvalidValue(f"{method} takes no body")
    if ep.is_command and ep.name not in ANYONE:
        devices.check_lease(local_name, token)
    try:
        path = ep.url(*request.args)
    except ValueError as exc:
        raise InvalidValue(str(exc), code="invalid_request") from exc
    return await conn.call(ep.method, path, payload, conn.generation)


async def stop_all(devices: DeviceRegistry) -> list[str]:
    """The pendant's STOP for every device that is not a robot: each one whose kind declares
    `stop` is sent it at once, connected or not (the attempt is logged when it fails). Robots
    halt through jog and their link sessions."""
    names: list[str] = []
    calls = []
    for name, conn in list(devices.connections.items()):
        kind = plugins().kinds.get(conn.record.kind)
        if kind is None or kind.session:
            continue
        try:
            ep = declared(kind).get("stop")
        except Unavailable as exc:
            log.warning("cannot stop %s: %s", name, exc.message)
            continue
        if ep is None or ep.params or ep.body is not None:
            continue
        names.append(name)
        calls.append(conn.call(ep.method, ep.url(), None, conn.generation))
    for name, result in zip(
        names, await asyncio.gather(*calls, return_exceptions=True), strict=True
    ):
        if isinstance(result, BaseException):
            log.warning("stop of %s failed: %s", name, result)
    return names
