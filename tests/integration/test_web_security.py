"""The attacks of a page on another site, or of a site whose name was re-pointed at the
runtime, against a running `openpendant run` (issue 15): each changes nothing."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import httpx
import numpy as np
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from runtime.bench.harness.jog import Cell, JogClient
from runtime.bench.harness.processes import Runtime

ATTACKER = "http://attacker.example"

# What a foreign page can send without asking the browser first: text/plain, no custom
# headers. The program moves a joint, closes the tool and switches an output on.
IMPORT = b"""variables:
- name: program.x
  type: program
  value:
    source: python
    python: |
      move_joints([0.35, -1.57, 0, -1.57, 0, 0])
      tool_close()
      set_output('robot.do0', True)
"""


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cell]:
    proc = Runtime(tmp_path_factory.mktemp("websec"))
    proc.wait_ready()
    try:
        added = Cell(proc)
        proc.api("DELETE", "/devices/robot/lease", headers=added.headers())
        yield added
    finally:
        proc.stop()
    assert proc.service_errors() == []


@pytest.fixture
def runtime(cell: Cell) -> Runtime:
    return cell.runtime


def joints(runtime: Runtime) -> np.ndarray[Any, Any]:
    return np.array(runtime.api("GET", "/devices/robot/state").json()["joint_position"])


def test_a_foreign_page_can_neither_import_a_program_nor_run_one(runtime: Runtime) -> None:
    before = joints(runtime)
    simple = {"content-type": "text/plain;charset=UTF-8", "origin": ATTACKER}
    imported = runtime.api("POST", "/variables/_import", content=IMPORT, headers=simple)
    assert imported.status_code == 403
    assert imported.json()["error"]["code"] == "origin_not_allowed"
    # Without its Origin (an old browser) the body type alone is refused.
    unasked = runtime.api(
        "POST", "/variables/_import", content=IMPORT, headers={"content-type": "text/plain"}
    )
    assert unasked.status_code == 415
    ran = runtime.api("POST", "/programs/x/run", headers={"origin": ATTACKER})
    assert ran.status_code == 403
    assert runtime.api("GET", "/programs/x").status_code == 404
    for answer in ("resume", "stop", "pause"):
        assert (
            runtime.api("POST", f"/programs/x/{answer}", headers={"origin": ATTACKER}).status_code
            == 403
        )
    assert runtime.api("GET", "/devices/robot/lease").json().get("holder") is None
    assert np.allclose(joints(runtime), before, atol=1e-6)
    state = runtime.api("GET", "/devices/robot/state").json()
    assert not any(state.get("digital_outputs", []))


def test_a_foreign_page_opens_no_socket_not_even_with_a_lease_token(cell: Cell) -> None:
    runtime = cell.runtime
    cell.ready()
    try:
        port = runtime.api("GET", "/jog/settings").json()["socket_port"]
        gateway = runtime.url.replace("http", "ws")
        for url in (
            f"ws://127.0.0.1:{port}/jog/ws",
            f"{gateway}/api/jog/ws",
            f"{gateway}/api/devices/ws",
            f"{gateway}/api/programs/_ws",
            f"{gateway}/api/variables/_events",
        ):
            with pytest.raises(InvalidStatus) as refused:
                connect(url, additional_headers={"Origin": ATTACKER}, open_timeout=5)
            assert refused.value.response.status_code == 403, url
        # The UI's own pages open the same socket and jog with the same token.
        before = joints(runtime)
        jog = JogClient(runtime, token=cell.token)
        try:
            jog.hold(0.4, kind="joint", axis=0, direction=1, speed=0.5)
            cell.robot.wait_stopped()
        finally:
            jog.close()
        assert not np.allclose(joints(runtime), before, atol=1e-3)
    finally:
        runtime.api("DELETE", "/devices/robot/lease", headers=cell.headers())


def test_a_rebound_name_reaches_nothing(runtime: Runtime) -> None:
    port = runtime.url.rsplit(":", 1)[1]
    rebound = {"host": f"attacker.example:{port}"}
    for method, path in (
        ("GET", "/devices"),
        ("GET", "/variables/_export"),
        ("POST", "/devices/_stop"),
    ):
        response = runtime.api(method, path, headers=rebound)
        assert response.status_code == 400, path
        assert response.json()["error"]["code"] == "host_not_allowed"
    assert httpx.get(runtime.url + "/", headers=rebound).status_code == 400
    with pytest.raises(InvalidStatus):
        connect(runtime.url.replace("http", "ws") + "/api/devices/ws", additional_headers=rebound)


def test_the_gateway_bounds_bodies_and_paths_and_sets_its_headers(runtime: Runtime) -> None:
    huge = runtime.api(
        "PUT",
        "/programs/big",
        content=b"x" * (17 * 1024 * 1024),
        headers={"content-type": "application/json"},
    )
    assert huge.status_code == 413
    climbed = httpx.get(runtime.url + "/api/programs/..%2fopenapi.json", headers=runtime.auth())
    assert climbed.status_code == 400
    page = httpx.get(runtime.url + "/")
    assert page.headers["x-content-type-options"] == "nosniff"
    assert "frame-ancestors 'none'" in page.headers["content-security-policy"]
