"""The runtime's services: one entry each. Adding a service is one line here plus its package;
the webui routes /api/<prefix>/… to the service that owns <prefix>."""

from __future__ import annotations

import importlib
import json
import os
import socket
from collections.abc import Callable
from dataclasses import dataclass

from fastapi import FastAPI
from starlette.responses import PlainTextResponse
from starlette.types import ASGIApp, Receive, Scope, Send

from runtime.kit.logs import setup_logging
from runtime.kit.serve import listening_socket, run_app
from runtime.kit.settings import RuntimeSettings, settings_from_env

URLS_ENV = "OPENPENDANT_SERVICE_URLS"

AppFactory = Callable[[RuntimeSettings, dict[str, str]], FastAPI]


@dataclass(frozen=True)
class ServiceSpec:
    name: str
    factory: str  # "module:function" that builds the app from (settings, service urls)
    prefixes: tuple[str, ...] = ()
    # Paths also served to browsers on a public port of the service's own (none: only
    # through the webui).
    public_paths: tuple[str, ...] = ()


SERVICES: tuple[ServiceSpec, ...] = (
    ServiceSpec("variable_storage", "runtime.variable_storage.service:build_app", ("variables",)),
    ServiceSpec("device_manager", "runtime.device_manager.service:build_app", ("devices",)),
    ServiceSpec("jog", "runtime.jog.service:build_app", ("jog",), public_paths=("/jog/ws",)),
    ServiceSpec("motion", "runtime.motion.service:build_app", ("motion",)),
    ServiceSpec("program", "runtime.program.service:build_app", ("programs",)),
)
WEBUI = ServiceSpec("webui", "webui.server:build_app")
ALL_SERVICES = {spec.name: spec for spec in (*SERVICES, WEBUI)}


def load_factory(spec: ServiceSpec) -> AppFactory:
    module, _, attr = spec.factory.partition(":")
    factory: AppFactory = getattr(importlib.import_module(module), attr)
    return factory


def urls_from_env() -> dict[str, str]:
    raw = os.environ.get(URLS_ENV, "{}")
    urls = json.loads(raw)
    if not isinstance(urls, dict):
        raise ValueError(f"{URLS_ENV} must be a JSON object")
    return {str(k): str(v) for k, v in urls.items()}


def run_service(
    name: str,
    *,
    fd: int | None,
    host: str,
    port: int | None,
    settings: RuntimeSettings | None = None,
    public_fd: int | None = None,
) -> None:
    """Run one service in this process, on an inherited socket or a port of its own, and on
    its public socket (inherited) if it has one."""
    spec = ALL_SERVICES[name]
    settings = settings or settings_from_env()
    setup_logging(name, settings.log_level)
    app: ASGIApp = load_factory(spec)(settings, urls_from_env())
    sock = socket.socket(fileno=fd) if fd is not None else listening_socket(host, port or 0)
    sockets = [sock]
    if public_fd is not None and spec.public_paths:
        public = socket.socket(fileno=public_fd)
        app = PublicPaths(app, int(public.getsockname()[1]), spec.public_paths)
        sockets.append(public)
    run_app(app, *sockets)


class PublicPaths:
    """On the public port only the service's public paths answer; the rest of its API is
    reached through the webui, as every other service's."""

    def __init__(self, app: ASGIApp, port: int, paths: tuple[str, ...]) -> None:
        self.app = app
        self.port = port
        self.paths = set(paths)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        server = scope.get("server")
        on_public = server is not None and server[1] == self.port
        if scope["type"] != "lifespan" and on_public and scope.get("path") not in self.paths:
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1008})
            else:
                await PlainTextResponse("not found", status_code=404)(scope, receive, send)
            return
        await self.app(scope, receive, send)
