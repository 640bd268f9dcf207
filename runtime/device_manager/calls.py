"""Calls of a device's interface methods through the device manager, for the UI and scripts:
`POST /devices/{name}/call/{method}` with `{"args": [path parameters], "body": {…}}`. Only
what the device's kind declares with `@endpoint` can be called, its body checked first; a
command needs the device's control lease, but for `stop`, which anyone may send. Robots are
not moved this way: their motion goes through jog (hold-to-run) and motion (planned,
checked moves)."""

from __future__ import annotations

from typing import Any

from pydantic import Field, ValidationError

from plugins.api import resolve
from plugins.registry import registry as plugins
from runtime.device_manager.registry import DeviceRegistry
from runtime.interfaces.common import Strict
from runtime.interfaces.endpoints import endpoints
from runtime.kit.app import describe_validation_errors
from runtime.kit.errors import Conflict, InvalidValue, NotFound

# Stop always wins: anyone may stop a device, control or not.
ANYONE = ("stop",)


class CallRequest(Strict):
    args: list[str | int] = Field(default_factory=list, max_length=8)
    body: dict[str, Any] | None = None


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
    ep = endpoints(resolve(kind.interface)).get(method)
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
    return await conn.call(ep.method, ep.url(*request.args), payload, conn.generation)
