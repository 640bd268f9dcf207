"""The app factory every service and driver uses: errors as JSON, /health, logging."""

from __future__ import annotations

import asyncio
import gc
import logging
import os
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from dataclasses import asdict
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from openpendant.runtime import __version__
from openpendant.runtime.kit.deadline import DeadlineMiddleware
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.kit.loop_watch import LoopWatch
from openpendant.runtime.kit.metrics import serve_metrics

log = logging.getLogger(__name__)

Lifespan = Callable[[FastAPI], AbstractAsyncContextManager[None]]
HealthProbe = Callable[[], Awaitable[dict[str, Any]]]


def error_response(status: int, code: str, message: str, **details: Any) -> JSONResponse:
    error: dict[str, Any] = {"code": code, "message": message}
    if details:
        error["details"] = details
    return JSONResponse({"error": error}, status_code=status)


def describe_validation_errors(errors: Any) -> tuple[str, list[dict[str, Any]]]:
    """A readable message plus JSON-safe details (inputs may hold NaN, so they are dropped)."""
    clean: list[dict[str, Any]] = []
    parts: list[str] = []
    for err in errors:
        loc = [str(p) for p in err.get("loc", ()) if p != "body"]
        where = ".".join(loc) or "body"
        msg = str(err.get("msg", "invalid"))
        clean.append({"loc": loc, "msg": msg, "type": str(err.get("type", ""))})
        parts.append(f"{where}: {msg}")
    return "; ".join(parts) or "invalid request", clean


def unreadable_body(exc: StarletteHTTPException) -> str | None:
    """What was wrong with a JSON body FastAPI could not read (it says only "There was an
    error parsing the body"; the cause says why)."""
    if exc.status_code != 400 or exc.detail != "There was an error parsing the body":
        return None
    cause = exc.__cause__
    if isinstance(cause, RecursionError):
        return "the JSON body is nested too deeply"
    if isinstance(cause, ValueError) and "digits" in str(cause):
        return "a number in the JSON body has too many digits"
    if isinstance(cause, UnicodeDecodeError):
        return "the JSON body is not UTF-8 text"
    return f"the JSON body could not be read ({type(cause).__name__})"


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(OpenPendantError)
    async def _domain(_: Request, exc: OpenPendantError) -> JSONResponse:
        return JSONResponse(exc.body(), status_code=exc.status)

    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        message, details = describe_validation_errors(exc.errors())
        return error_response(422, "invalid_request", message, errors=details)

    @app.exception_handler(StarletteHTTPException)
    async def _http(_: Request, exc: StarletteHTTPException) -> JSONResponse:
        unreadable = unreadable_body(exc)
        if unreadable is not None:
            return error_response(400, "bad_body", unreadable)
        code = {404: "not_found", 405: "method_not_allowed"}.get(exc.status_code, "http_error")
        return error_response(exc.status_code, code, str(exc.detail))

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error on %s %s", request.method, request.url.path)
        return error_response(500, "internal_error", f"{type(exc).__name__}: {exc}")


def _freeze_startup_objects() -> None:
    """What start-up loaded (the web stack, URDF models) lives as long as the process. A full
    garbage collection over it takes ~25 ms, a stall a 2 ms control loop or a 100 Hz state
    stream would feel; frozen objects are skipped by every later collection."""
    gc.collect()
    gc.freeze()


def _build_routes(app: FastAPI) -> None:
    """FastAPI (0.165) builds the routes of an included router at the first request that
    reaches it, pydantic's schemas and all: 100-170 ms with the event loop held (the loop
    watch saw it in the device manager, whose robot links go stale after 200 ms). Built
    here, at start-up, before anything is served. A FastAPI that builds them eagerly has
    nothing to build."""
    pending: list[Any] = list(app.router.routes)
    while pending:
        route = pending.pop()
        build = getattr(route, "effective_candidates", None)
        if callable(build):
            pending.extend(build())
        low = getattr(route, "effective_low_priority_routes", None)
        if callable(low):
            low()


def plugin_failures() -> list[dict[str, str]]:
    """What of the plugins this process could not load (the System panel shows them)."""
    from openpendant.plugins.registry import registry

    return [asdict(failure) for failure in registry().failures]


def create_app(
    service: str,
    *,
    lifespan: Lifespan | None = None,
    health: HealthProbe | None = None,
    metrics_route: bool = True,
) -> FastAPI:
    """`metrics_route`: serve this process's own series at /metrics (the gateway serves
    everyone's there instead)."""
    started = time.time()

    @asynccontextmanager
    async def _lifespan(app: FastAPI) -> AsyncIterator[None]:
        watch = asyncio.create_task(LoopWatch().run(), name="loop watch")
        try:
            if lifespan is None:
                _build_routes(app)
                _freeze_startup_objects()
                yield
                return
            async with lifespan(app):
                _build_routes(app)
                _freeze_startup_objects()
                yield
        finally:
            watch.cancel()

    app = FastAPI(title=f"OpenPendant {service}", version=__version__, lifespan=_lifespan)
    install_error_handlers(app)
    app.add_middleware(DeadlineMiddleware)
    serve_metrics(app, route=metrics_route)

    @app.get("/health")
    async def _health() -> dict[str, Any]:
        body: dict[str, Any] = {
            "status": "ok",
            "service": service,
            "version": __version__,
            "pid": os.getpid(),
            "uptime_s": round(time.time() - started, 3),
        }
        if health is not None:
            body.update(await health())
        failures = plugin_failures()
        if failures:
            body["plugin_failures"] = failures
        return body

    return app
