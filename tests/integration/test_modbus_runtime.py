"""Modbus devices in a running runtime, as a user adds them: the simulated I/O block and a
simulated Robotiq gripper (`openpendant driver modbus-io|modbus-gripper --simulate`),
commanded through the device manager with control and by programs' blocks."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from openpendant.runtime.bench.harness.processes import DriverProc, Runtime, wait_for


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    home = tmp_path_factory.mktemp("modbus-runtime")
    started = Runtime(home, extra=["--no-sim"])
    try:
        started.wait_ready()
        yield started
    finally:
        started.stop()


def added(runtime: Runtime, driver: str, name: str, *options: str) -> Iterator[str]:
    device = DriverProc(runtime.home, driver, name.replace("_", "-"), "--simulate", *options)
    try:
        url = device.wait_ready()
        answer = runtime.api("POST", "/devices", json={"url": url, "local_name": name})
        assert answer.status_code in (200, 201), answer.text
        yield url
    finally:
        device.stop()


@pytest.fixture(scope="module")
def cell_io(runtime: Runtime) -> Iterator[str]:
    yield from added(runtime, "modbus-io", "cell_io")


@pytest.fixture(scope="module")
def gripper(runtime: Runtime) -> Iterator[str]:
    yield from added(runtime, "modbus-gripper", "gripper", "--profile", "robotiq-2f-85")


def finished(runtime: Runtime, program: str, python: str) -> dict[str, Any]:
    """Saves and runs a program; its status once it has ended."""
    assert runtime.api("PUT", f"/programs/{program}", json={"python": python}).status_code == 200
    assert runtime.api("POST", f"/programs/{program}/run", json={}).status_code == 202

    def status() -> dict[str, Any]:
        answer: dict[str, Any] = runtime.api("GET", f"/programs/{program}/status").json()
        return answer

    wait_for(
        lambda: status()["state"] in ("finished", "failed", "error", "stopped"), 30, what="its end"
    )
    return status()


def test_a_simulated_block_added_to_the_runtime_is_read_and_switched_through_it(
    runtime: Runtime, cell_io: str
) -> None:
    """`openpendant driver modbus-io --simulate`: added, its input seen change through the
    runtime, an output switched with control (and refused without it); a program's digital
    and analog I/O blocks on its signals by name."""
    url = cell_io
    if True:

        def value(name: str) -> Any:
            state = runtime.api("GET", "/devices/cell_io/state").json()
            return state.get("values", {}).get(name, "missing")

        wait_for(lambda: value("part_present") is False, 10, what="the block polled")
        httpx.put(f"{url}/sim/signals/part_present", json={"value": True}, timeout=5)
        wait_for(lambda: value("part_present") is True, 10, what="the input seen")
        switch = {"args": ["lamp_green"], "body": {"value": True}}
        refused = runtime.api("POST", "/devices/cell_io/call/write", role="operator", json=switch)
        assert refused.status_code == 409, refused.text
        assert httpx.get(f"{url}/sim/signals/lamp_green", timeout=5).json()["value"] is False
        lease = runtime.api(
            "POST", "/devices/cell_io/lease", role="operator", json={"holder": "tablet"}
        ).json()["token"]
        done = runtime.api(
            "POST",
            "/devices/cell_io/call/write",
            role="operator",
            json=switch,
            headers={"X-Lease-Token": lease},
        )
        assert done.status_code == 200 and done.json()["value"] is True, done.text
        assert httpx.get(f"{url}/sim/signals/lamp_green", timeout=5).json()["value"] is True
        wait_for(lambda: value("lamp_green") is True, 10, what="the output in the state")
        runtime.api("DELETE", "/devices/cell_io/lease", headers={"X-Lease-Token": lease})

        # The I/O blocks of a program work on the block's signals by name.
        httpx.put(f"{url}/sim/signals/part_present", json={"value": False}, timeout=5)
        httpx.put(f"{url}/sim/signals/air_pressure", json={"value": 6.25}, timeout=5)
        program = (
            "set_output('cell_io.lamp_red', True)\n"
            "wait_for_input('cell_io.part_present', True, 30)\n"
            "set_output('cell_io.feeder_run', get_input('cell_io.door_closed') == False)\n"
            "set_output('cell_io.lamp_red', False)\n"
            "set_analog_output('cell_io.feeder_speed', get_analog('cell_io.air_pressure') * 10)\n"
        )
        saved = runtime.api("PUT", "/programs/io_check", json={"python": program})
        assert saved.status_code == 200, saved.text
        assert runtime.api("POST", "/programs/io_check/run", json={}).status_code == 202

        def lamp_red() -> bool:
            return bool(httpx.get(f"{url}/sim/signals/lamp_red", timeout=5).json()["value"])

        wait_for(lamp_red, 20, what="the program switching the red lamp on")
        status = runtime.api("GET", "/programs/io_check/status").json()
        assert status["state"] == "running"  # waiting for the part
        httpx.put(f"{url}/sim/signals/part_present", json={"value": True}, timeout=5)
        wait_for(
            lambda: (
                runtime.api("GET", "/programs/io_check/status").json()["state"]
                in ("finished", "failed")
            ),
            30,
            what="the program's end",
        )
        final = runtime.api("GET", "/programs/io_check/status").json()
        assert final["state"] == "finished", final
        assert httpx.get(f"{url}/sim/signals/feeder_run", timeout=5).json()["value"] is True
        assert not lamp_red()
        speed = httpx.get(f"{url}/sim/signals/feeder_speed", timeout=5).json()["value"]
        assert speed == pytest.approx(62.5)
        bad = "set_output('cell_io.part_present', True)\n"
        assert runtime.api("PUT", "/programs/io_bad", json={"python": bad}).status_code == 200
        assert runtime.api("POST", "/programs/io_bad/run", json={}).status_code == 202
        wait_for(
            lambda: runtime.api("GET", "/programs/io_bad/status").json()["state"] == "error",
            30,
            what="writing an input refused",
        )
        error = runtime.api("GET", "/programs/io_bad/status").json()["error"]
        assert error["code"] == "read_only" and "part_present is an input" in error["message"]


def test_a_simulated_gripper_is_commanded_with_control_and_by_the_gripper_blocks(
    runtime: Runtime, gripper: str
) -> None:
    def state() -> dict[str, Any]:
        answer: dict[str, Any] = runtime.api("GET", "/devices/gripper/state").json()
        return answer

    wait_for(lambda: state().get("connected") is True, 10, what="the gripper polled")
    assert state()["activated"] is False
    refused = runtime.api("POST", "/devices/gripper/call/activate", role="operator", json={})
    assert refused.status_code == 409, refused.text  # no control, no command
    lease = runtime.api(
        "POST", "/devices/gripper/lease", role="operator", json={"holder": "tablet"}
    ).json()["token"]
    mine = {"X-Lease-Token": lease}
    call = "/devices/gripper/call/"
    done = runtime.api("POST", call + "activate", role="operator", json={}, headers=mine)
    assert done.status_code == 200 and done.json()["activated"] is True, done.text
    httpx.put(f"{gripper}/sim/object", json={"width": 0.025}, timeout=5)
    closed = runtime.api("POST", call + "close", role="operator", json={"body": {}}, headers=mine)
    assert closed.status_code == 200, closed.text
    assert closed.json()["object_detected"] is True
    assert closed.json()["position"] == pytest.approx(0.025, abs=0.001)
    runtime.api("DELETE", "/devices/gripper/lease", headers=mine)

    # The gripper blocks: force set for the run, close on the part, wait for the grip, open.
    program = (
        "gripper_open('gripper')\n"
        "gripper_set_force('gripper', 60)\n"
        "gripper_close('gripper')\n"
        "gripper_wait_for_grip('gripper', 5)\n"
        "if not gripper_holds_part('gripper'):\n"
        "    stop_program()\n"
        "gripper_open('gripper')\n"
    )
    final = finished(runtime, "grip", program)
    assert final["state"] == "finished", final
    fingers = httpx.get(f"{gripper}/sim/fingers", timeout=5).json()
    assert fingers["width"] == pytest.approx(0.085)

    too_hard = finished(runtime, "grip_hard", "gripper_set_force('gripper', 500)\n")
    assert too_hard["error"]["code"] == "invalid_value", too_hard
    assert "235" in too_hard["error"]["message"]
    nothing = finished(runtime, "grip_none", "gripper_close('cell')\n")
    assert nothing["error"]["code"] == "unknown_device", nothing

    # Taken away, the fingers close on nothing: the wait for a grip fails after its time.
    httpx.put(f"{gripper}/sim/object", json={"width": None}, timeout=5)
    empty = finished(
        runtime, "grip_empty", "gripper_close('gripper')\ngripper_wait_for_grip('gripper', 0.5)\n"
    )
    assert empty["error"]["code"] == "timeout" and "did not grip" in empty["error"]["message"]
