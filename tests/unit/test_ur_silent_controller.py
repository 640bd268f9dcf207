"""A UR whose controller does not answer (issue 31): the driver goes on publishing its state
at its rate, every state an error with `communication_failure`, so the runtime's link to the
driver stays connected the whole time instead of flapping between `connected` and `stale`.

The real driver (ur-rtde underneath) served as its host serves it, in this process, and the
device manager's real link to it, for 10 s. The controller is a loopback address whose
dashboard port takes connections and never says a word: every attempt to reach it holds the
driver's control thread for ur-rtde's 2.5 s timeout."""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import socket
import threading
import time
from collections.abc import AsyncIterator, Callable, Iterator

import uvicorn

from openpendant.device_drivers.ur_rtde.driver import URDriver
from openpendant.runtime.device_manager.connection import DeviceConnection
from openpendant.runtime.drivers.host import build_driver_app
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.robot import RobotState
from openpendant.runtime.interfaces.variables import DeviceRecord
from openpendant.runtime.kit.serve import listening_socket
from openpendant.runtime.kit.settings import LinkSettings
from openpendant.runtime.robotics.robot_info import load_robot_info

# The dashboard's port is fixed: an address of this run's own, so that two runs of the
# suite on one machine do not meet there.
CONTROLLER = f"127.31.{os.getpid() % 250 + 1}.{os.getpid() // 250 % 250 + 2}"
DASHBOARD_PORT = 29999
OBSERVED = 10.0  # s of the driver's own state timestamps
UR5E = load_robot_info("ur5e")


@contextlib.contextmanager
def silent_controller() -> Iterator[None]:
    """A dashboard port that accepts every connection and answers nothing."""
    server = socket.create_server((CONTROLLER, DASHBOARD_PORT))
    server.settimeout(0.1)
    held: list[socket.socket] = []
    done = threading.Event()

    def accept() -> None:
        while not done.is_set():
            with contextlib.suppress(TimeoutError):
                held.append(server.accept()[0])

    thread = threading.Thread(target=accept, name="silent-dashboard", daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()
        for conn in held:
            conn.close()
        server.close()


async def until(check: Callable[[], object], what: str, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, f"{what}: not within {timeout} s"
        await asyncio.sleep(0.01)


@contextlib.asynccontextmanager
async def served_driver() -> AsyncIterator[str]:
    """The UR driver's app, as `openpendant driver ur-rtde` serves it (its state at 100 Hz)."""
    identity = DeviceIdentity(uuid="ur-silent", kind="robot", model=UR5E.model, name="ur")
    driver = URDriver(identity, UR5E, CONTROLLER)
    app = build_driver_app(
        driver, advertisement=None, interfaces=["127.0.0.1"], state_rate_hz=100.0
    )
    sock = listening_socket("127.0.0.1", 0)
    server = uvicorn.Server(uvicorn.Config(app, log_config=None, lifespan="on"))
    task = asyncio.create_task(server.serve(sockets=[sock]))
    try:
        await until(lambda: server.started, "the driver serving")
        yield f"http://127.0.0.1:{sock.getsockname()[1]}"
    finally:
        server.should_exit = True
        await asyncio.wait({task}, timeout=10.0)


def test_a_silent_controller_is_a_steady_fault_not_a_flapping_link() -> None:
    statuses: list[str] = []
    states: list[RobotState] = []

    async def scenario() -> None:
        async with served_driver() as url:
            record = DeviceRecord(
                uuid="ur-silent", local_name="ur", kind="robot", model="m", name="ur", url=url
            )
            conn = DeviceConnection(
                record,
                lambda _, text: states.append(RobotState.model_validate(json.loads(text))),
                lambda c: statuses.append(c.status),
                LinkSettings(),  # the runtime's own: stale after 200 ms without a new state
            )
            conn.start()
            try:
                await until(lambda: conn.status == "connected", "the link to the driver")
                generation = conn.generation
                first = states[0].ts
                await until(
                    lambda: states[-1].ts >= first + OBSERVED,
                    f"{OBSERVED:.0f} s of states",
                    timeout=OBSERVED * 3,
                )
                assert statuses == ["connected"], statuses
                assert conn.status == "connected" and conn.generation == generation
            finally:
                await conn.stop()

    with silent_controller():
        asyncio.run(scenario())
    assert len({s.seqno for s in states}) == len(states)  # every one news
    for state in states:
        flags = state.flags
        assert flags.error and flags.communication_failure, state
        assert not flags.ready and not flags.enabled
        assert state.error_message
    assert f"cannot reach the robot at {CONTROLLER}" in states[-1].error_message
