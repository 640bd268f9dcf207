"""The webui service: serves the built UI and routes /api/<prefix>/… to the services."""

from __future__ import annotations

import asyncio
import contextlib
import os
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any, Literal

import httpx
from fastapi import FastAPI, Query, Request, Response, WebSocket
from fastapi.responses import FileResponse, HTMLResponse
from fastapi.staticfiles import StaticFiles
from prometheus_client import CONTENT_TYPE_LATEST
from pydantic import BaseModel, ConfigDict

from openpendant.runtime.auth.audit import AUDIT_FILE, AuditLog
from openpendant.runtime.auth.setup import SETUP_CODE_ENV, auth_store
from openpendant.runtime.kit.app import create_app
from openpendant.runtime.kit.errors import NotFound
from openpendant.runtime.kit.https_redirect import ca_response
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.kit.tls import CA_DOWNLOAD, lan_download, tls_files
from openpendant.runtime.kit.web_guard import WebGuard
from openpendant.runtime.paths import package_roots
from openpendant.runtime.services import services as declared_services
from openpendant.runtime.services import web_policy
from openpendant.webui.access import AccessGuard
from openpendant.webui.auth_routes import auth_router
from openpendant.webui.logs import MAX_ENTRIES, LogEntry, recent_entries
from openpendant.webui.metrics import gathered
from openpendant.webui.plugins import plugins_router
from openpendant.webui.proxy import ServiceProxy

DIST = Path(__file__).resolve().parent / "frontend" / "dist"

NOT_BUILT = """<!doctype html><meta charset="utf-8"><title>OpenPendant</title>
<body style="font:18px sans-serif;padding:2em"><h1>The UI has not been built</h1>
<p>Run <code>make run</code> (it builds the UI), or <code>make ui</code>.</p>
<p>The API is up: <a href="/api/health">/api/health</a></p></body>"""

METHODS = ["GET", "POST", "PUT", "PATCH", "DELETE"]


class ServiceHealth(BaseModel):
    """A service's own health answer (with what else it says, e.g. its plugin failures), or
    what the gateway found when it asked."""

    model_config = ConfigDict(extra="allow")

    status: str  # "ok", "starting", "down", or a service's own word
    service: str | None = None
    version: str | None = None
    pid: int | None = None
    uptime_s: float | None = None
    url: str | None = None
    message: str | None = None


class Health(BaseModel):
    status: Literal["ok", "degraded"]
    services: dict[str, ServiceHealth]


async def service_health(client: httpx.AsyncClient, name: str, base: str) -> dict[str, Any]:
    try:
        response = await client.get(f"{base}/health", timeout=1.0)
        body = response.json()
    except (httpx.HTTPError, ValueError):
        return {"status": "down", "url": base}
    if response.status_code != 200:
        message = body.get("error", {}).get("message", "") if isinstance(body, dict) else ""
        return {"status": "starting", "url": base, "message": message}
    return {**body, "url": base}


ROBOT_FILE_TYPES = {".urdf", ".xacro", ".dae", ".stl", ".obj", ".mtl", ".png", ".jpg", ".jpeg"}


def robot_file_path(package: str, path: str) -> Path:
    root = package_roots().get(package)
    if root is None:
        raise NotFound(f"no URDF package {package!r}")
    target = (root / path).resolve()
    if not target.is_relative_to(root.resolve()) or not target.is_file():
        raise NotFound(f"no file {path!r} in {package}")
    if target.suffix.lower() not in ROBOT_FILE_TYPES:
        raise NotFound(f"{target.suffix} files are not served")
    return target


def build_app(settings: RuntimeSettings, urls: dict[str, str]) -> FastAPI:
    routes = {
        prefix: (spec.name, urls[spec.name])
        for spec in declared_services()
        if spec.name in urls
        for prefix in spec.prefixes
    }
    proxy = ServiceProxy(routes)

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        try:
            yield
        finally:
            await proxy.aclose()
            store.close()
            audit.close()

    app = create_app("webui", lifespan=lifespan, metrics_route=False)
    store = auth_store(settings)
    audit = AuditLog(settings.data_dir / AUDIT_FILE)
    # Outermost first: the guard of what a browser may send, then who it is.
    app.add_middleware(AccessGuard, store=store, audit=audit)
    app.add_middleware(WebGuard, policy=web_policy(settings))
    tls = tls_files(settings)
    setup_code = os.environ.get(SETUP_CODE_ENV) or None
    lan = lan_download(settings) if tls is not None else None
    app.include_router(auth_router(store, audit, setup_code, tls, lan))
    if tls is not None and tls.ca is not None:
        authority = tls.ca

        @app.get(CA_DOWNLOAD, include_in_schema=False)
        async def certificate_authority() -> Response:
            """The runtime's certificate authority, for a tablet to trust (public)."""
            return ca_response(authority)

    @app.get("/api/health")
    async def health() -> Health:
        names = [spec.name for spec in declared_services()]
        results = await asyncio.gather(
            *(service_health(proxy.http, name, urls[name]) for name in names if name in urls)
        )
        services: dict[str, Any] = {"webui": {"status": "ok", "pid": os.getpid()}}
        services.update(dict(zip([n for n in names if n in urls], results, strict=True)))
        missing = [n for n in names if n not in urls]
        for name in missing:
            services[name] = {"status": "down", "message": "no address configured"}
        ok = all(s.get("status") == "ok" for s in services.values())
        return Health.model_validate({"status": "ok" if ok else "degraded", "services": services})

    app.include_router(plugins_router(urls, proxy.http))

    @app.get("/metrics", include_in_schema=False)
    async def metrics() -> Response:
        """Every service's series for Prometheus (webui/metrics.py)."""
        named = {spec.name: urls[spec.name] for spec in declared_services() if spec.name in urls}
        return Response(await gathered(proxy.http, named), media_type=CONTENT_TYPE_LATEST)

    @app.get("/api/robot-files/{package}/{path:path}")
    async def robot_file(package: str, path: str) -> FileResponse:
        """URDFs and meshes for the 3D view, from the installed URDF packages."""
        return FileResponse(
            robot_file_path(package, path), headers={"Cache-Control": "public, max-age=3600"}
        )

    @app.get("/api/logs")
    async def logs(
        level: Literal["debug", "info", "warning", "error"] = "warning",
        limit: int = Query(100, ge=1, le=MAX_ENTRIES),
    ) -> list[LogEntry]:
        """The runtime's recent log entries at `level` or above, newest first."""
        return await asyncio.to_thread(recent_entries, settings.logs, level, limit)

    @app.api_route("/api/{prefix}", methods=METHODS)
    async def api_root(request: Request, prefix: str) -> Response:
        return await proxy.forward(request, prefix, "")

    @app.api_route("/api/{prefix}/{path:path}", methods=METHODS)
    async def api(request: Request, prefix: str, path: str) -> Response:
        return await proxy.forward(request, prefix, path)

    @app.websocket("/api/{prefix}/{path:path}")
    async def api_ws(ws: WebSocket, prefix: str, path: str) -> None:
        await proxy.forward_ws(ws, prefix, path)

    if (DIST / "index.html").is_file():
        app.mount("/", StaticFiles(directory=DIST, html=True), name="ui")
    else:

        @app.get("/", response_class=HTMLResponse)
        async def not_built() -> str:
            return NOT_BUILT

    return app
