"""The rr-tool driver (plugins/robotraconteur) against an RR standard tool, an electric
gripper (tests/support/rr_sim_tool.py), over rr+tcp on loopback with RR's discovery off: its
info read from the tool, nothing moves before it is activated, open, close, a grip on an
object, a move to a width, a stop midway, the tool's error a fault until it is activated
again, and the tool gone a fault said in the state and by every command until it is back."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator
from typing import Any

import pytest

from openpendant.plugins.robotraconteur.entry import RRToolOptions, create_tool
from openpendant.plugins.robotraconteur.tool_driver import RRTool, ToolFault
from openpendant.runtime.bench.harness.processes import wait_for
from openpendant.runtime.interfaces.gripper import GripperMotion
from openpendant.runtime.kit.errors import DeviceError, InvalidValue
from tests.support.rr_service import RRService
from tests.support.rr_sim_tool import STROKE

# No real-time margins here (seconds-long waits): beside the real-time tests, at nice 19.
pytestmark = pytest.mark.concurrent
MM = 1e-3


class ToolProcess(RRService):
    def __init__(self, port: int | None = None) -> None:
        super().__init__("rr_sim_tool", "tool", port=port)

    def set(self, name: str, value: Any, kind: str = "double[]") -> None:
        super().set(name, [value], kind)


class Driven:
    """The driver made as its host makes it, on its own loop in this thread."""

    def __init__(self, url: str) -> None:
        self.loop = asyncio.new_event_loop()
        driver = create_tool("gripper", "rr-tool-1", RRToolOptions(url=url, reconnect=0.2))
        assert isinstance(driver, RRTool)
        self.driver = driver
        self.run(driver.start())
        wait_for(lambda: driver.state().connected, 5, what="the first state")

    def run(self, work: Any) -> Any:
        return self.loop.run_until_complete(work)

    def close(self) -> None:
        self.run(self.driver.shutdown())
        self.loop.close()


@pytest.fixture
def tool() -> Iterator[list[ToolProcess]]:
    """The tool (a list: a test may start it again on its port)."""
    started = [ToolProcess()]
    yield started
    for each in started:
        each.kill()


@pytest.fixture
def driven(tool: list[ToolProcess]) -> Iterator[Driven]:
    driven = Driven(tool[0].url)
    yield driven
    driven.close()


def test_it_opens_closes_grips_and_moves_once_activated(
    tool: list[ToolProcess], driven: Driven
) -> None:
    d = driven.driver
    assert d.info.model == "RR test gripper" and d.info.stroke == pytest.approx(STROKE)
    assert d.info.capabilities == ["position", "object_detection"]
    state = d.state()
    assert state.connected and not state.activated and state.fault == ""
    with pytest.raises(InvalidValue, match="activate"):
        driven.run(d.close(GripperMotion()))
    assert driven.run(d.activate()).activated

    closed = driven.run(d.close(GripperMotion()))
    assert closed.position == pytest.approx(0.0, abs=MM) and not closed.object_detected
    opened = driven.run(d.open(GripperMotion()))
    assert opened.position == pytest.approx(STROKE, abs=MM) and not opened.moving

    tool[0].set("object", 0.04)  # a part 40 mm wide between the fingers
    gripped = driven.run(d.close(GripperMotion()))
    assert gripped.object_detected and gripped.position == pytest.approx(0.04, abs=MM)
    tool[0].set("object", 0.0)
    moved = driven.run(d.move(GripperMotion(position=0.06)))
    assert moved.position == pytest.approx(0.06, abs=MM) and not moved.object_detected
    with pytest.raises(InvalidValue, match="at most"):
        driven.run(d.move(GripperMotion(position=0.2)))


def test_a_stop_halts_the_fingers_midway(driven: Driven) -> None:
    d = driven.driver
    driven.run(d.activate())
    driven.run(d.open(GripperMotion()))
    closing = driven.loop.create_task(d.close(GripperMotion()))
    driven.run(asyncio.sleep(0.1))
    wait_for(lambda: d.state().moving, 5, what="closing")
    driven.run(d.stop())
    driven.run(closing)  # the close ends where the fingers stopped
    at = d.state().position
    assert at is not None and 0.005 < at < STROKE - 0.005, at
    driven.run(asyncio.sleep(0.3))
    assert d.state().position == pytest.approx(at, abs=1e-6)


def test_the_tools_error_is_a_fault_until_activated_again(
    tool: list[ToolProcess], driven: Driven
) -> None:
    d = driven.driver
    driven.run(d.activate())
    tool[0].set("fault", 1)
    wait_for(lambda: "error" in d.state().fault, 5, what="the fault shown")
    assert not d.state().activated
    with pytest.raises(InvalidValue, match="activate"):
        driven.run(d.open(GripperMotion()))
    state = driven.run(d.activate())  # resets its errors and enables it
    assert state.activated and state.fault == ""
    assert driven.run(d.close(GripperMotion())).position == pytest.approx(0.0, abs=MM)


def test_the_tool_gone_is_a_fault_until_it_is_back(tool: list[ToolProcess], driven: Driven) -> None:
    d = driven.driver
    driven.run(d.activate())
    port = tool[0].port
    tool[0].kill()
    wait_for(lambda: not d.state().connected, 5, what="the loss seen")
    assert "tool" in d.state().fault
    with pytest.raises(DeviceError):
        driven.run(d.open(GripperMotion()))
    tool.append(ToolProcess(port))
    wait_for(lambda: d.state().connected, 10, what="connected again")
    assert not d.state().activated  # a tool that restarted is activated again first
    assert driven.run(d.activate()).activated
    with pytest.raises(ToolFault):  # the tool's own refusal, in its words
        driven.run(d._call("a command out of range", lambda c: c.setf_command(1.0)))
