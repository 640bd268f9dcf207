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


def test_robot_files_are_served_from_packages_and_nothing_else() -> None:
    app = build_app(RuntimeSettings(sim=False), {})
    with TestClient(app) as client:
        urdf = client.get(
            "/api/robot-files/example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"
        )
        assert urdf.status_code == 200
        assert "shoulder_pan_joint" in urdf.text
        mesh = client.get(
            "/api/robot-files/example-robot-data/robots/ur_description/meshes/ur5/visual/base.dae"
        )
        assert mesh.status_code == 200
        for bad in (
            "example-robot-data/../../../../../etc/passwd",
            "example-robot-data/robots/ur_description/README.md",
            "no-such-package/x.urdf",
        ):
            response = client.get(f"/api/robot-files/{bad}")
            assert response.status_code == 404, bad
