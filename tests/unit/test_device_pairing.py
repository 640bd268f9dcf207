"""A device's proof of pairing is bound to the address it serves from (issue 31): a device's
real guard (runtime/drivers/guard.py) and a relay that passes its challenges on, both served
over real HTTP on loopback, and the device manager's registry deciding whether a link follows
an announcement."""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections.abc import AsyncIterator, Callable, Coroutine
from pathlib import Path
from typing import Any

import httpx
import pytest
import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route
from starlette.types import ASGIApp

from openpendant.runtime.device_manager.addresses import unsettled
from openpendant.runtime.device_manager.connection import DeviceConnection
from openpendant.runtime.device_manager.models import AddDeviceRequest
from openpendant.runtime.device_manager.registry import DeviceRegistry
from openpendant.runtime.drivers.guard import CommandGuard
from openpendant.runtime.interfaces.variables import DeviceRecord
from openpendant.runtime.kit.device_auth import address_text, disproof, keep_secret, proof
from openpendant.runtime.kit.discovery import Detected
from openpendant.runtime.kit.errors import Conflict, OpenPendantError
from openpendant.runtime.kit.serve import listening_socket
from openpendant.runtime.kit.websocket import Fanout
from openpendant.runtime.variable_storage.client import StorageClient

UUID = "paired-robot-1"
SECRET = "the-boards-own-pairing-secret"
NOWHERE = "http://127.0.0.1:9"  # the robot's old address: nothing answers there


class Served:
    """An ASGI app on a loopback port of its own, in this event loop."""

    def __init__(self, app: ASGIApp, host: str = "127.0.0.1", dial: str = "127.0.0.1") -> None:
        self.sock = listening_socket(host, 0)
        self.port = int(self.sock.getsockname()[1])
        self.url = f"http://{dial}:{self.port}"
        config = uvicorn.Config(app, log_config=None, lifespan="off")
        self.server = uvicorn.Server(config)
        self._task: asyncio.Task[None] | None = None

    async def __aenter__(self) -> Served:
        self._task = asyncio.create_task(self.server.serve(sockets=[self.sock]))
        await until(lambda: self.server.started)
        return self

    async def __aexit__(self, *_: object) -> None:
        self.server.should_exit = True
        assert self._task is not None
        await asyncio.wait({self._task}, timeout=5.0)


def device(secret: str = SECRET) -> ASGIApp:
    """A paired device: its guard in front of what it says it is."""

    async def info(_: Request) -> JSONResponse:
        identity = {"uuid": UUID, "kind": "robot", "model": "m", "name": "board"}
        return JSONResponse({"identity": identity})

    return CommandGuard(Starlette(routes=[Route("/info", info)]), secret)


def relay(upstream: str) -> ASGIApp:
    """An impostor that passes every challenge on to the real device and its answer back."""

    async def forward(request: Request) -> Response:
        async with httpx.AsyncClient(base_url=upstream, timeout=2.0) as http:
            answer = await http.get(request.url.path, params=request.query_params)
        return Response(answer.content, answer.status_code, media_type="application/json")

    return Starlette(routes=[Route("/pair/proof", forward), Route("/info", forward)])


async def until(check: Callable[[], object], timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, "timed out"
        await asyncio.sleep(0.01)


def run(scenario: Callable[[], Coroutine[Any, Any, None]]) -> None:
    asyncio.run(scenario())


# The proof ---------------------------------------------------------------------------------


def test_a_genuine_proof_from_the_devices_own_address_is_accepted() -> None:
    async def scenario() -> None:
        async with Served(device()) as board:
            assert await disproof(board.url, SECRET) is None
            # It is the secret that proves: another one does not.
            assert await disproof(board.url, "another-secret-entirely") == "a wrong proof"

    run(scenario)


def test_a_device_bound_to_every_interface_proves_the_address_it_was_reached_at() -> None:
    async def scenario() -> None:
        async with Served(device(), host="0.0.0.0", dial="127.0.0.2") as board:
            async with httpx.AsyncClient() as http:
                params = {"nonce": "n" * 16}
                answer = (await http.get(f"{board.url}/pair/proof", params=params)).json()
            assert answer["address"] == f"127.0.0.2:{board.port}"
            assert await disproof(board.url, SECRET) is None

    run(scenario)


def test_a_proof_relayed_from_another_address_is_refused() -> None:
    async def scenario() -> None:
        async with Served(device()) as board, Served(relay(board.url)) as impostor:
            # The relay really passes the real device's proof on...
            nonce = "a-fresh-challenge"
            params = {"nonce": nonce}
            async with httpx.AsyncClient() as http:
                answer = (await http.get(f"{impostor.url}/pair/proof", params=params)).json()
            own = address_text("127.0.0.1", board.port)
            assert answer == {"proof": proof(SECRET, nonce, own), "address": own}
            # ... which proves the device's address, not the impostor's.
            refused = await disproof(impostor.url, SECRET)
            assert refused is not None and "passed on" in refused, refused

    run(scenario)


def test_addresses_are_compared_as_both_ends_spell_them() -> None:
    assert address_text("::ffff:10.77.1.2", 80) == "10.77.1.2:80"
    assert address_text("fe80:0:0::1%veth0", 80) == "[fe80::1]:80"
    assert address_text("Board.Local", 80) == "board.local:80"


# Following a device ------------------------------------------------------------------------


@contextlib.asynccontextmanager
async def added_robot(data_dir: Path) -> AsyncIterator[tuple[DeviceRegistry, DeviceConnection]]:
    """The registry with the robot added at its old address, its link down (not started: no
    session will connect), its pairing secret kept."""
    keep_secret(data_dir, UUID, SECRET)
    storage = StorageClient(NOWHERE, timeout=0.5)  # the new address cannot be stored: logged
    registry = DeviceRegistry(storage, Fanout(), data_dir=data_dir)
    record = DeviceRecord(
        uuid=UUID, local_name="robot", kind="robot", model="m", name="board", url=NOWHERE
    )
    conn = DeviceConnection(
        record,
        lambda *_: None,
        lambda _: None,
        secret=lambda: registry.secret_of(UUID),
    )
    conn.status = "disconnected"
    registry.connections["robot"] = conn
    registry.loaded = True
    try:
        yield registry, conn
    finally:
        await asyncio.gather(*registry._tasks, *conn._halts.values(), return_exceptions=True)
        await storage.aclose()


def announced(url: str) -> Detected:
    host, port = url.removeprefix("http://").rsplit(":", 1)
    return Detected(
        uuid=UUID,
        kind="robot",
        model="m",
        name="board",
        api="1",
        host=host,
        port=int(port),
        service_name=f"board-{port}._openpendant._tcp.local.",
    )


def test_a_link_that_is_down_does_not_follow_a_relayed_proof(tmp_path: Path) -> None:
    async def scenario() -> None:
        async with (
            Served(device()) as board,
            Served(relay(board.url)) as impostor,
            added_robot(tmp_path) as (registry, conn),
        ):
            registry.on_found(announced(impostor.url))
            await until(lambda: "robot" in registry.claims)
            await asyncio.gather(*registry._tasks)
            claim = registry.claims["robot"]
            assert conn.record.url == NOWHERE
            assert claim.url == impostor.url and not claim.followed and not claim.proven
            assert registry.details("robot").address_claim == claim

    run(scenario)


def test_a_link_that_is_down_follows_the_device_proven_at_its_new_address(
    tmp_path: Path,
) -> None:
    async def scenario() -> None:
        async with Served(device()) as board, added_robot(tmp_path) as (registry, conn):
            registry.on_found(announced(board.url))
            await until(lambda: conn.record.url == board.url)
            claim = registry.claims["robot"]
            assert claim.url == NOWHERE and claim.followed

    run(scenario)


MOVING = {
    "flags": {"enabled": True},
    "joint_velocity": [0.4, 0.0, 0.0, 0.0, 0.0, 0.0],
}
FAULTED = {"flags": {"protective_stop": True}, "joint_velocity": [0.0] * 6}
AT_REST = {"flags": {"enabled": True}, "joint_velocity": [0.0001, 0.0, 0.0, 0.0, 0.0, 0.0]}


def test_the_last_state_says_whether_a_robot_was_at_rest() -> None:
    assert unsettled(json.dumps(MOVING)) == "it was moving"
    assert "protective_stop" in unsettled(json.dumps(FAULTED))
    running = {"flags": {"trajectory_running": True}, "joint_velocity": [0.0] * 6}
    assert unsettled(json.dumps(running)) == "it was moving"
    assert unsettled(json.dumps(AT_REST)) == ""
    assert unsettled(None) == ""


def test_a_proven_device_waits_for_the_user_while_its_robot_was_moving_faulted_or_live(
    tmp_path: Path,
) -> None:
    async def scenario() -> None:
        for pinned in ("moving", "faulted", "live"):
            async with Served(device()) as board, added_robot(tmp_path) as (registry, conn):
                if pinned == "live":
                    conn.status = "connected"
                else:
                    conn.held = unsettled(json.dumps(MOVING if pinned == "moving" else FAULTED))
                registry.on_found(announced(board.url))
                await until(lambda: (c := registry.claims.get("robot")) is not None and c.proven)
                await asyncio.gather(*registry._tasks)
                claim = registry.claims["robot"]
                assert conn.record.url == NOWHERE, pinned
                assert claim.url == board.url and not claim.followed, pinned
                assert registry.details("robot").address_claim == claim
                # The user confirms: the link moves (the robot halted first).
                moved = await registry.repoint("robot", board.url)
                assert moved.url == board.url and conn.record.url == board.url

    run(scenario)


def test_a_device_added_with_the_key_kept_here_must_prove_it_holds_it(tmp_path: Path) -> None:
    """Review of issue 32: the Devices panel marks a device whose announced key id matches
    a key this runtime keeps "paired: no pairing code needed"; that id is public, anyone may
    copy it. Added so, what answers at the announced address must prove it holds the key."""

    async def scenario() -> None:
        keep_secret(tmp_path, UUID, SECRET)
        storage = StorageClient(NOWHERE, timeout=0.5)
        registry = DeviceRegistry(storage, Fanout(), data_dir=tmp_path)
        registry.loaded = True
        request = AddDeviceRequest(uuid=UUID, local_name="robot")
        try:
            async with Served(device("another boards secret")) as impostor:
                registry.on_found(announced(impostor.url))
                with pytest.raises(Conflict) as refused:
                    await registry.add(request)
                assert refused.value.code == "unproven"
                assert "robot" not in registry.connections
            async with Served(device()) as board:
                registry.on_found(announced(board.url))
                # Proven: it goes on to be stored (here the storage is away: refused there).
                with pytest.raises(OpenPendantError) as stopped:
                    await registry.add(request)
                assert stopped.value.code != "unproven"
        finally:
            await storage.aclose()

    run(scenario)
