"""No command for a caller that is gone (issue 31), at the device manager's link socket: a
program run claims its robot under its id, the motion service's commands for the run name
that claim; when the run's service goes away its claims end before the halt, and a call or
a streamed command under an ended claim never reaches the device."""

from __future__ import annotations

import asyncio
import json
from typing import Any, cast

from openpendant.runtime.device_manager.links import LinkClient, LinkServer


class FakeConnection:
    """The device's side as the links see it: what reached it, in order."""

    def __init__(self) -> None:
        self.name = "robot"
        self.generation = 3
        self.received: list[str] = []
        self.gate: asyncio.Event | None = None  # holds a call on its way, when set

    async def call(
        self, method: str, path: str, body: Any, generation: int, text: str | None = None
    ) -> tuple[int, Any]:
        if self.gate is not None:
            await self.gate.wait()
        self.received.append(f"{method} {path}")
        return 200, {}

    def send(self, command: dict[str, Any], generation: int, on_refused: Any) -> None:
        self.received.append(str(command["type"]))

    def halt(self, tag: str | None = None) -> bool:
        self.received.append(f"halt {tag}")
        return True


class FakeRegistry:
    def __init__(self, conn: FakeConnection) -> None:
        self.connections = {"robot": conn}


def setup() -> tuple[LinkServer, FakeConnection, LinkClient, LinkClient]:
    conn = FakeConnection()
    links = LinkServer(cast(Any, FakeRegistry(conn)))
    program, motion = LinkClient(cast(Any, None)), LinkClient(cast(Any, None))
    program.service, motion.service = "program", "motion"
    return links, conn, program, motion


def replies(client: LinkClient) -> list[dict[str, Any]]:
    found = [json.loads(e) for e in client._events]
    return [e for e in found if e.get("type") in ("reply", "refused")]


def claim(links: LinkServer, program: LinkClient, run: str) -> None:
    links._handle(program, {"op": "claim", "device": "robot", "gen": 3, "claim": run})


async def call(links: LinkServer, motion: LinkClient, run: str, path: str = "/trajectory") -> None:
    message = {"op": "call", "ref": 1, "device": "robot", "gen": 3, "method": "POST"}
    await links._call(motion, {**message, "path": path, "claim": run})


def test_a_call_under_a_live_claim_reaches_the_device() -> None:
    async def scenario() -> None:
        links, conn, program, motion = setup()
        claim(links, program, "run-1")
        await call(links, motion, "run-1")
        assert conn.received == ["POST /trajectory"]
        assert replies(motion)[-1]["status"] == 200

    asyncio.run(scenario())


def test_when_the_runs_service_goes_its_claim_ends_before_the_halt() -> None:
    async def scenario() -> None:
        links, conn, program, motion = setup()
        claim(links, program, "run-1")
        links._left(program)  # its socket closed: killed
        assert conn.received == ["halt program link closed"]
        await call(links, motion, "run-1")
        assert conn.received == ["halt program link closed"]  # the trajectory never went
        reply = replies(motion)[-1]
        assert reply["status"] == 409 and reply["body"]["error"]["code"] == "claim_ended"
        stream = {"type": "velocity_command", "velocity": [0.1] * 6}
        links._send(motion, {"op": "send", "device": "robot", "gen": 3, "command": stream,
                             "claim": "run-1"})  # fmt: skip
        assert conn.received == ["halt program link closed"]
        assert replies(motion)[-1]["error"]["code"] == "claim_ended"

    asyncio.run(scenario())


def test_a_run_that_unclaims_has_no_later_command_run() -> None:
    async def scenario() -> None:
        links, conn, program, motion = setup()
        claim(links, program, "run-1")
        links._handle(program, {"op": "unclaim", "device": "robot", "claim": "run-1"})
        await call(links, motion, "run-1")
        assert conn.received == []

    asyncio.run(scenario())


def test_a_call_waits_for_the_claim_on_its_way_and_not_for_one_that_never_comes() -> None:
    async def scenario() -> None:
        links, conn, program, motion = setup()
        waiting = asyncio.create_task(call(links, motion, "run-2"))
        await asyncio.sleep(0.05)
        assert conn.received == []  # held until the run's claim arrives
        claim(links, program, "run-2")
        await waiting
        assert conn.received == ["POST /trajectory"]
        await call(links, motion, "run-never")  # about a second, then refused
        assert conn.received == ["POST /trajectory"]
        assert replies(motion)[-1]["body"]["error"]["code"] == "claim_ended"

    asyncio.run(scenario())


def test_a_call_whose_claim_ends_on_its_way_is_followed_by_a_halt() -> None:
    """The halt of the service that went away may overtake a call already on its way to
    the driver: another halt follows the call."""

    async def scenario() -> None:
        links, conn, program, motion = setup()
        claim(links, program, "run-1")
        conn.gate = asyncio.Event()
        on_its_way = asyncio.create_task(call(links, motion, "run-1"))
        await asyncio.sleep(0.02)
        links._left(program)
        conn.gate.set()
        await on_its_way
        assert conn.received == ["halt program link closed", "POST /trajectory", "halt run-1 ended"]

    asyncio.run(scenario())


def test_a_stream_under_a_claim_that_never_came_is_refused() -> None:
    async def scenario() -> None:
        links, conn, _, motion = setup()
        stream = {"type": "velocity_command", "velocity": [0.1] * 6}
        message = {"op": "send", "device": "robot", "gen": 3, "command": stream}
        links._send(motion, {**message, "claim": "run-dead"})
        assert conn.received == []
        assert replies(motion)[-1]["error"]["code"] == "claim_ended"

    asyncio.run(scenario())


def test_what_a_claim_started_on_a_new_link_is_halted_when_its_claimant_goes() -> None:
    """The robot's link was made again during the run (generation 3 -> 4): the run's next
    move went on the new one, so the run's service going away halts that one too."""

    async def scenario() -> None:
        links, conn, program, motion = setup()
        claim(links, program, "run-1")  # on generation 3
        conn.generation = 4
        message = {"op": "call", "ref": 2, "device": "robot", "gen": 4, "method": "POST"}
        await links._call(motion, {**message, "path": "/trajectory", "claim": "run-1"})
        links._left(program)
        assert conn.received == ["POST /trajectory", "halt program link closed"]

    asyncio.run(scenario())
