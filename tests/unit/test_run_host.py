"""The program service's side of a run, with the device layer replaced by recording fakes:
a handler's own bug fails its block with an answer (the run never hangs), and a stop that
lands while a command is on its way to a device leaves that device stopped."""

from __future__ import annotations

import asyncio
from types import SimpleNamespace
from typing import Any, cast

import pytest

from openpendant.runtime.program import host as host_module
from openpendant.runtime.program.host import RunHost
from openpendant.sandbox.supervisor import CallRefused


class Belt:
    """A device client whose command waits until the test lets it arrive."""

    def __init__(self, events: list[str]) -> None:
        self.events = events
        self.arrive = asyncio.Event()
        self.sent = asyncio.Event()

    async def run(self) -> None:
        self.events.append("run sent")
        self.sent.set()
        await self.arrive.wait()
        self.events.append("run arrived")

    async def stop(self) -> None:
        self.events.append("stop")


class FakeDevices:
    def __init__(self, belt: Belt) -> None:
        self.belt = belt

        async def take_lease(device: str, holder: str) -> Any:
            return SimpleNamespace(token=f"token-{device}")

        self.manager = SimpleNamespace(take_lease=take_lease)

    async def client(self, name: str, kind: str) -> Belt:
        return self.belt

    async def check_lease(self, name: str, token: str) -> None:
        return None


def make_host(devices: Any = None) -> RunHost:
    motion = SimpleNamespace()
    return RunHost(
        "tests", cast(Any, devices), cast(Any, motion), cast(Any, None), robot=None, leases={}
    )


def test_a_handler_that_fails_on_its_own_bug_fails_its_block(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    async def broken(run: RunHost, args: dict[str, Any]) -> None:
        raise RuntimeError("a bug in a plugin")

    monkeypatch.setattr(host_module, "handlers", lambda: {"broken": broken})
    with pytest.raises(CallRefused) as refused:
        asyncio.run(make_host().call("broken", {}))
    assert refused.value.code == "handler_failed"
    assert "a bug in a plugin" in refused.value.message


async def run_belt(run: RunHost, args: dict[str, Any]) -> None:
    client = cast(Belt, await run.device("belt", "conveyor"))
    await client.run()


@pytest.fixture
def events(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """What reached the belt, in order; the run's only call runs it."""
    monkeypatch.setattr(host_module, "handlers", lambda: {"run_belt": run_belt})
    return []


def test_a_stop_during_a_command_leaves_the_device_stopped(events: list[str]) -> None:
    async def scenario() -> None:
        belt = Belt(events)
        host = make_host(FakeDevices(belt))
        call = asyncio.create_task(host.call("run_belt", {}))
        await belt.sent.wait()
        await host.halt()  # its stop overtakes the run command still on its way
        belt.arrive.set()
        await call
        assert events[-1] == "stop", events
        with pytest.raises(CallRefused) as refused:
            await host.call("run_belt", {})
        assert refused.value.code == "stopped"

    asyncio.run(scenario())


def test_a_stop_while_the_device_is_looked_up_sends_nothing(events: list[str]) -> None:
    async def scenario() -> None:
        looked_up = asyncio.Event()
        go_on = asyncio.Event()

        class SlowDevices(FakeDevices):
            async def check_lease(self, name: str, token: str) -> None:
                looked_up.set()
                await go_on.wait()

        host = make_host(SlowDevices(Belt(events)))
        call = asyncio.create_task(host.call("run_belt", {}))
        await looked_up.wait()
        await host.halt()
        go_on.set()
        with pytest.raises(CallRefused) as refused:
            await call
        assert refused.value.code == "stopped"

    asyncio.run(scenario())
    assert "run sent" not in events


def test_a_devices_kind_is_asked_once_per_run() -> None:
    """An input waited on is read every few milliseconds: its device's kind is looked up
    once, and an unknown device is still refused by name."""
    from openpendant.blockly_blocks.io.handlers import signal_of
    from openpendant.runtime.kit.errors import NotFound

    asked: list[str] = []

    async def device(name: str) -> Any:
        asked.append(name)
        if name != "cell_io":
            raise NotFound(f"no device {name}")
        return SimpleNamespace(kind="io")

    devices = SimpleNamespace(manager=SimpleNamespace(device=device))
    run = make_host(devices)

    async def reads() -> None:
        for _ in range(3):
            assert await signal_of(run, "cell_io.part_present") == ("cell_io", "io", "part_present")
        with pytest.raises(CallRefused) as refused:
            await signal_of(run, "gone.lamp")
        assert refused.value.code == "unknown_device"

    asyncio.run(reads())
    assert asked == ["cell_io", "gone"]
