"""A driver's routes, generated from the `@endpoint` declarations of its interface: one route
per declared method, its body and answer models as declared, every accepted command kept in
the driver's command log."""

from __future__ import annotations

import inspect
from collections.abc import Callable, Coroutine
from typing import Any

from fastapi import APIRouter, Query, Response

from openpendant.runtime.drivers.command_log import CommandLog, LoggedCommand
from openpendant.runtime.interfaces.endpoints import Endpoint, endpoints, param_types

Handler = Callable[..., Coroutine[Any, Any, Any]]


def interface_router(driver: Any, log: CommandLog) -> APIRouter:
    """Every endpoint the driver's class declares (its kind's interface and its own)."""
    router = APIRouter()

    @router.get("/command_log")
    async def command_log(after: int = Query(0, ge=0, le=2**53)) -> list[LoggedCommand]:
        """Commands this driver accepted, newest last (the last 2000)."""
        return log.since(after)

    declared = type(driver)
    for ep in endpoints(declared).values():
        router.add_api_route(
            ep.path,
            _handler(driver, declared, ep, log),
            methods=[ep.method],
            name=ep.name,
            response_model=ep.returns,
            status_code=200 if ep.returns is not None else 204,
            description=(inspect.getdoc(getattr(declared, ep.name)) or ""),
        )
    return router


def _handler(driver: Any, declared: type[Any], ep: Endpoint, log: CommandLog) -> Handler:
    method = getattr(driver, ep.name)
    params = param_types(declared, ep)

    async def handle(**kwargs: Any) -> Any:
        args = tuple(kwargs[name] for name in params)
        if ep.body is not None:
            args += (kwargs["body"],)
        result = await method(*args)
        if ep.is_command:
            log.record(*ep.describe(args, result))
        return result if ep.returns is not None else Response(status_code=204)

    parameters = [
        inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, annotation=kind)
        for name, kind in params.items()
    ]
    if ep.body is not None:
        parameters.append(
            inspect.Parameter("body", inspect.Parameter.KEYWORD_ONLY, annotation=ep.body)
        )
    handle.__signature__ = inspect.Signature(parameters)  # type: ignore[attr-defined]
    handle.__name__ = ep.name
    return handle
