"""The webui server on its own: routing and what it says when a service is not there."""

from __future__ import annotations

from fastapi.testclient import TestClient

from runtime.kit.settings import RuntimeSettings
from tests.support.processes import free_port
from webui.server import build_app


def test_a_service_that_is_not_running_is_a_503_not_a_hang() -> None:
    dead = f"http://127.0.0.1:{free_port()}"
    app = build_app(RuntimeSettings(sim=False), {"device_manager": dead, "variable_storage": dead})
    with TestClient(app) as client:
        response = client.get("/api/devices/detected")
        assert response.status_code == 503
        assert response.json()["error"]["code"] == "service_unavailable"
        health = client.get("/api/health").json()
    assert health["status"] == "degraded"
    assert health["services"]["device_manager"]["status"] == "down"
    assert health["services"]["webui"]["status"] == "ok"


def test_a_service_without_an_address_is_reported() -> None:
    app = build_app(RuntimeSettings(sim=False), {})
    with TestClient(app) as client:
        assert client.get("/api/devices").status_code == 404
        health = client.get("/api/health").json()
    assert health["services"]["variable_storage"]["status"] == "down"
