"""The webui server on its own: routing and what it says when a service is not there."""

from __future__ import annotations

import json
from pathlib import Path

from fastapi.testclient import TestClient

from openpendant.runtime.auth.setup import create_token
from openpendant.runtime.bench.harness.processes import free_port
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.webui.server import build_app


def gateway(data: Path, urls: dict[str, str], logs: Path | None = None) -> TestClient:
    """The webui app, asked by an administrator's API token."""
    app = build_app(RuntimeSettings(sim=False, data_dir=data, log_dir=logs), urls)
    token = create_token(data, "admin", "tests")
    return TestClient(
        app, base_url="http://127.0.0.1:8080", headers={"Authorization": f"Bearer {token}"}
    )


def test_a_service_that_is_not_running_is_a_503_not_a_hang(tmp_path: Path) -> None:
    dead = f"http://127.0.0.1:{free_port()}"
    with gateway(tmp_path, {"device_manager": dead, "variable_storage": dead}) as client:
        response = client.get("/api/devices/detected")
        assert response.status_code == 503
        assert response.json()["error"]["code"] == "service_unavailable"
        health = client.get("/api/health").json()
    assert health["status"] == "degraded"
    assert health["services"]["device_manager"]["status"] == "down"
    assert health["services"]["webui"]["status"] == "ok"


def test_a_service_without_an_address_is_reported(tmp_path: Path) -> None:
    with gateway(tmp_path, {}) as client:
        assert client.get("/api/devices").status_code == 404
        health = client.get("/api/health").json()
    assert health["services"]["variable_storage"]["status"] == "down"


def test_robot_files_are_served_from_packages_and_nothing_else(tmp_path: Path) -> None:
    with gateway(tmp_path, {}) as client:
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


def test_the_log_route_gives_recent_entries_by_level_newest_first(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "jog.log").write_text(
        "\n".join(
            [
                json.dumps({"ts": 1.0, "level": "info", "service": "jog", "msg": "started"}),
                "Traceback (most recent call last): not a JSON line",
                json.dumps({"ts": 3.0, "level": "error", "service": "jog", "msg": "it failed"}),
            ]
        )
    )
    # A big file: only its tail is read, and the first (cut) line of the tail is skipped.
    filler = json.dumps({"ts": 0.5, "level": "warning", "service": "dm", "msg": "x" * 1000})
    lines = [filler] * 400 + [json.dumps({"ts": 2.0, "level": "warning", "msg": "late"})]
    (logs / "device_manager.log").write_text("\n".join(lines))
    with gateway(tmp_path, {}, logs) as client:
        warnings = client.get("/api/logs").json()
        everything = client.get("/api/logs?level=info&limit=500").json()
        assert client.get("/api/logs?level=loud").status_code == 422
        assert client.get("/api/logs?limit=0").status_code == 422
    assert [e["message"] for e in warnings[:2]] == ["it failed", "late"]
    assert warnings[1]["service"] == "device_manager"  # named by its file when it says none
    assert all(e["level"] != "info" for e in warnings)
    assert "started" in [e["message"] for e in everything]
    assert len(everything) < 401  # the tail, not the whole file
