"""Hold-to-run and single point of control, at the default 100 ms deadman window: heartbeats
that stop, a socket that closes, a client without the lease, a jog service that dies."""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterator

import httpx
import pytest
from prometheus_client.parser import text_string_to_metric_families

from openpendant.runtime.bench.harness.jog import Cell, JogClient
from openpendant.runtime.bench.harness.processes import Runtime, wait_for


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cell]:
    runtime = Runtime(tmp_path_factory.mktemp("deadman"))
    runtime.wait_ready()
    try:
        yield Cell(runtime)
    finally:
        runtime.stop()


@pytest.fixture
def jog(cell: Cell) -> Iterator[JogClient]:
    cell.ready()
    client = JogClient(cell.runtime, token=cell.token)
    yield client
    client.close()


def test_heartbeats_stopping_halt_the_robot(cell: Cell, jog: JogClient) -> None:
    after = cell.robot.last_command_seq()
    press = jog.press(kind="cartesian", axis="x", direction=1, speed=0.3)
    for _ in range(10):  # held for a while, then the client goes quiet (frozen, not closed)
        jog.send({"type": "heartbeat", "press": press})
        jog.drain(0.03)
    status = jog.status(press, ("halted",), timeout=2)
    assert "heartbeat" in status["reason"]
    cell.robot.wait_stopped(2)
    log = cell.robot.commands(after)
    assert any(e["type"] == "halt" and e["tag"] == f"{press}:halt" for e in log)
    # Heartbeats arriving late do not bring it back.
    quiet = cell.robot.last_command_seq()
    for _ in range(5):
        jog.send({"type": "heartbeat", "press": press})
        jog.drain(0.03)
    assert [e for e in cell.robot.commands(quiet) if e["type"] != "halt"] == []
    assert cell.robot.stopped()


def test_closing_the_socket_halts_and_reconnecting_does_not_resume(
    cell: Cell, jog: JogClient
) -> None:
    after = cell.robot.last_command_seq()
    press = jog.press(kind="joint", axis=0, direction=1, speed=0.5)
    for _ in range(5):
        jog.send({"type": "heartbeat", "press": press})
        jog.drain(0.02)
    jog.close()
    cell.robot.wait_stopped(2)
    assert any(e["type"] == "halt" for e in cell.robot.commands(after))
    again = JogClient(cell.runtime, token=cell.token)
    try:
        quiet = cell.robot.last_command_seq()
        again.send({"type": "heartbeat", "press": press})
        again.drain(0.3)
        assert cell.robot.commands(quiet) == []
        assert cell.robot.stopped()
        assert cell.robot.state()["command_mode"] == "halt"
    finally:
        again.close()


def test_a_client_without_the_lease_cannot_move_the_robot(cell: Cell, jog: JogClient) -> None:
    other = JogClient(cell.runtime, token=None)
    forged = JogClient(cell.runtime, token="not-the-token")
    try:
        before = cell.robot.last_command_seq()
        for client in (other, forged):
            press = client.press(kind="joint", axis=0, direction=1, speed=0.5)
            refused = client.status(press, ("refused",))
            assert refused["reason"] in ("lease_required", "lease_held")
        power = cell.runtime.api("POST", "/jog/robots/robot/disable")
        assert power.status_code == 409
        assert [e for e in cell.robot.commands(before) if e["type"] != "halt"] == []
        # But anyone may stop it.
        assert cell.runtime.api("POST", "/jog/robots/robot/halt").status_code == 200
    finally:
        other.close()
        forged.close()


def test_jogging_a_robot_that_is_not_ready_is_refused(cell: Cell, jog: JogClient) -> None:
    cell.robot.http.post("/sim/estop", json={"engaged": True})
    press = jog.press(kind="joint", axis=0, direction=1, speed=0.5)
    refused = jog.status(press, ("refused",))
    # Refused by the jog service (from its state feed) or by the driver: the same answer.
    assert refused["reason"] == "estop"
    assert "E-stop" in refused["message"]
    bad = jog.press(kind="joint", axis=9, direction=1)
    assert jog.status(bad, ("refused",))["state"] == "refused"
    jog.send(
        {"type": "jog", "press": "x", "robot": "robot", "kind": "joint", "axis": 0, "direction": 2}
    )
    errors = [m for m in jog.drain(0.5) if m.get("type") == "error"]
    assert errors
    assert errors[-1]["error"]["code"] == "invalid_request"


def test_the_drivers_timeout_stops_the_robot_if_the_jog_service_dies(
    cell: Cell, jog: JogClient
) -> None:
    press = jog.press(kind="joint", axis=5, direction=1, speed=0.5)
    jog.send({"type": "heartbeat", "press": press})
    jog.drain(0.1)
    pid = int(cell.runtime.api("GET", "/health").json()["services"]["jog"]["pid"])
    os.kill(pid, signal.SIGKILL)
    killed = time.monotonic()
    cell.robot.wait_stopped(2)
    assert time.monotonic() - killed < 1.0
    wait_for(
        lambda: cell.runtime.api("GET", "/health").json()["services"]["jog"]["status"] == "ok",
        30,
        what="jog service back",
    )


def test_service_errors_stay_clean_after_a_deliberate_kill(cell: Cell) -> None:
    """The jog service was killed on purpose above; nothing else may have logged errors."""
    errors = [e for e in cell.runtime.service_errors() if not e.startswith("jog.log")]
    assert errors == []


def scraped(runtime: Runtime) -> dict[str, dict[tuple[tuple[str, str], ...], float]]:
    """GET /metrics as Prometheus reads it (prometheus-client's own parser), with a viewer's
    token: {sample name: {labels: value}}."""
    answer = httpx.get(f"{runtime.url}/metrics", headers=runtime.auth("viewer"), timeout=10)
    assert answer.status_code == 200, answer.text
    found: dict[str, dict[tuple[tuple[str, str], ...], float]] = {}
    for family in text_string_to_metric_families(answer.text):
        found.setdefault(family.name, {})
        for sample in family.samples:
            found.setdefault(sample.name, {})[tuple(sorted(sample.labels.items()))] = sample.value
    return found


def value(series: dict[tuple[tuple[str, str], ...], float], **labels: str) -> float:
    return sum(v for key, v in series.items() if set(labels.items()) <= set(key))


def test_metrics_carry_every_series_and_change_under_a_jog(cell: Cell, jog: JogClient) -> None:
    assert httpx.get(f"{cell.runtime.url}/metrics", timeout=10).status_code == 401
    before = scraped(cell.runtime)
    families = {
        "openpendant_service_up",
        "openpendant_device_link_up",
        "openpendant_device_state_age_seconds",
        "openpendant_device_states",
        "openpendant_protective_stops",
        "openpendant_deadman_halts",
        "openpendant_path_deviations",
        "openpendant_program_runs",
        "openpendant_request_seconds",
        "process_resident_memory_bytes",
        "process_cpu_seconds",
    }
    assert families <= set(before)
    services = ("webui", "device_manager", "jog", "motion", "program", "variable_storage", "vision")
    for service in services:
        assert value(before["openpendant_service_up"], service=service) == 1.0
        assert value(before["process_resident_memory_bytes"], service=service) > 0
    assert value(before["openpendant_device_link_up"], device="robot") == 1.0
    assert value(before["openpendant_device_state_age_seconds"], device="robot") >= 0
    assert value(before["openpendant_program_runs_total"], end="error") == 0

    press = jog.press(kind="joint", axis=0, direction=1, speed=0.3)
    for _ in range(5):  # held, then the tablet goes quiet: the deadman halts it
        jog.send({"type": "heartbeat", "press": press})
        jog.drain(0.03)
    jog.status(press, ("halted",), timeout=2)
    cell.robot.wait_stopped(2)

    after = scraped(cell.runtime)
    assert (
        value(after["openpendant_deadman_halts_total"], robot="robot")
        == value(before.get("openpendant_deadman_halts_total", {}), robot="robot") + 1
    )
    states = "openpendant_device_states_total"
    assert value(after[states], device="robot") > value(before[states], device="robot")
    jog_requests = "openpendant_request_seconds_count"
    assert value(after[jog_requests]) > value(before[jog_requests])
    cpu = "process_cpu_seconds_total"
    assert value(after[cpu], service="jog") >= value(before[cpu], service="jog")
