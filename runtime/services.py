"""Running the runtime's services. A service is a package with a `build_app(settings, urls)`
and a `Service` declaration in a plugin (the core's are in `runtime/plugin.py`); the
launcher starts every declared service, and the webui routes /api/<prefix>/… to the
service that owns <prefix>."""

from __future__ import annotations

import importlib
import json
import os
import socket
from collections.abc import Callable

from fastapi import FastAPI
from starlette.responses import PlainTextResponse
from starlette.types import ASGIApp, Receive, Scope, Send

from openpendant.plugins.api import Service
from openpendant.plugins.registry import registry
from openpendant.runtime.auth.audit import AUDIT_FILE, AuditLog
from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.setup import sign_ins
from openpendant.runtime.kit.https_redirect import HttpsRedirect
from openpendant.runtime.kit.logs import setup_logging
from openpendant.runtime.kit.serve import Listener, listening_socket, run_app, run_listeners
from openpendant.runtime.kit.service_guard import InternalOnly, TicketRequired
from openpendant.runtime.kit.settings import RuntimeSettings, settings_from_env
from openpendant.runtime.kit.tls import tls_files
from openpendant.runtime.kit.uploads import UPLOADS
from openpendant.runtime.kit.web_guard import WebGuard, WebPolicy

URLS_ENV = "OPENPENDANT_SERVICE_URLS"

AppFactory = Callable[[RuntimeSettings, dict[str, str]], FastAPI]


WEBUI = Service("webui", "openpendant.webui.server:build_app")


def services() -> tuple[Service, ...]:
    """The runtime's services: the core's and every plugin's (plugins/api.py `Service`)."""
    return tuple(registry().services.values())


def all_services() -> dict[str, Service]:
    return {spec.name: spec for spec in (*services(), WEBUI)}


def load_factory(spec: Service) -> AppFactory:
    module, _, attr = spec.factory.partition(":")
    factory: AppFactory = getattr(importlib.import_module(module), attr)
    return factory


def urls_from_env() -> dict[str, str]:
    raw = os.environ.get(URLS_ENV, "{}")
    urls = json.loads(raw)
    if not isinstance(urls, dict):
        raise ValueError(f"{URLS_ENV} must be a JSON object")
    return {str(k): str(v) for k, v in urls.items()}


def web_policy(settings: RuntimeSettings) -> WebPolicy:
    return WebPolicy(
        ui_port=settings.port,
        allowed_hosts=settings.allowed_hosts,
        max_body=settings.max_request_bytes,
        jog_port=settings.jog_port or None,
        uploads=UPLOADS,
        scheme="https" if settings.tls.enabled else "http",
    )


def run_service(
    name: str,
    *,
    fd: int | None,
    host: str,
    port: int | None,
    settings: RuntimeSettings | None = None,
    public_fd: int | None = None,
    redirect_fd: int | None = None,
) -> None:
    """Run one service in this process, on an inherited socket or a port of its own, and on
    its public socket (inherited) if it has one. With TLS on, the UI's socket and a public
    socket speak HTTPS, and the UI's plain-HTTP socket (`redirect_fd`) sends browsers there;
    the internal sockets (loopback, between the runtime's own processes) stay plain."""
    spec = all_services()[name]
    settings = settings or settings_from_env()
    setup_logging(name, settings.log_level)
    files = tls_files(settings)
    tls = None if files is None else files.server_context
    app: ASGIApp = load_factory(spec)(settings, urls_from_env())
    sock = socket.socket(fileno=fd) if fd is not None else listening_socket(host, port or 0)
    if name == WEBUI.name:
        # The gateway is the door (webui/access.py).
        listeners = [Listener(app, [sock], tls)]
        if redirect_fd is not None:
            redirect = HttpsRedirect(
                web_policy(settings), settings.port, files.ca if files is not None else None
            )
            listeners.append(Listener(redirect, [socket.socket(fileno=redirect_fd)]))
        run_listeners(*listeners)
        return
    # Every other service answers only the gateway and its peers.
    internal = InternalOnly(app)
    if public_fd is None or not spec.public_paths:
        run_app(internal, sock)
        return
    public = socket.socket(fileno=public_fd)
    # What a browser reaches directly: the UI's origin only, with an operator's ticket.
    audit = AuditLog(settings.data_dir / AUDIT_FILE)
    ticketed = TicketRequired(app, Role.operator, sign_ins(settings), audit)
    guarded = WebGuard(ticketed, web_policy(settings))
    only = PublicPaths(guarded, spec.public_paths)
    run_listeners(Listener(internal, [sock]), Listener(only, [public], tls))


class PublicPaths:
    """On the public port only the service's public paths answer; the rest of its API is
    reached through the webui, as every other service's."""

    def __init__(self, guarded: ASGIApp, paths: tuple[str, ...]) -> None:
        self.guarded = guarded
        self.paths = set(paths)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "lifespan" and scope.get("path") not in self.paths:
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1008})
            else:
                await PlainTextResponse("not found", status_code=404)(scope, receive, send)
            return
        # What a browser reaches directly is guarded as the UI's port is.
        await self.guarded(scope, receive, send)
