"""What a process counts for the plant's monitoring, in Prometheus' text format
(prometheus-client): its own CPU and memory (the client's process collector), how long it
takes to answer each route, and what its service adds (links, deadman halts, path
deviations, program runs). Each service serves its own at `GET /metrics` on its internal
port; the gateway gathers them all under one `GET /metrics` on the UI's port, each series
labelled with its service (webui/metrics.py)."""

from __future__ import annotations

import time

from fastapi import FastAPI, Response
from prometheus_client import CONTENT_TYPE_LATEST, REGISTRY, Counter, Histogram, generate_latest
from starlette.types import ASGIApp, Receive, Scope, Send

REQUEST_SECONDS = Histogram(
    "openpendant_request_seconds",
    "Time a service took to answer a request, by route",
    ["method", "route"],
    buckets=(0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0),
)
DEADMAN_HALTS = Counter(
    "openpendant_deadman_halts", "Jogs halted because their heartbeats stopped", ["robot"]
)
PATH_DEVIATIONS = Counter(
    "openpendant_path_deviations",
    "Moves stopped as a protective stop because the arm left the path that was checked",
    ["robot"],
)
PROGRAM_RUNS = Counter(
    "openpendant_program_runs", "Program runs ended, by how (finished, stopped, error)", ["end"]
)
for _end in ("finished", "stopped", "error"):
    PROGRAM_RUNS.labels(_end)  # each shown from the start, at 0


class RequestTimer:
    """Times every HTTP request by the route it matched (its template, never the raw path:
    a name in a path would make a series per name)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = time.perf_counter()
        try:
            await self.app(scope, receive, send)
        finally:
            route = getattr(scope.get("route"), "path", "unmatched")
            REQUEST_SECONDS.labels(scope["method"], route).observe(time.perf_counter() - started)


def serve_metrics(app: FastAPI, route: bool = True) -> None:
    app.add_middleware(RequestTimer)
    if not route:
        return

    @app.get("/metrics", include_in_schema=False)
    async def metrics() -> Response:
        return Response(generate_latest(REGISTRY), media_type=CONTENT_TYPE_LATEST)
