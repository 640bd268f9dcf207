"""A Robot Raconteur standard tool (`com.robotraconteur.robotics.tool.Tool`): an electric
parallel gripper of 85 mm stroke for the RR tests. `python -m tests.support.rr_sim_tool PORT`
serves it on 127.0.0.1:PORT as service `tool` and prints `READY`.

Its fingers move at `SPEED` towards the opening commanded (`open`, `close`, `setf_command`
in metres of opening) and stop on an object: `setf_param("object", width)` puts one of that
width between them (0: none), and a grip stopped on it is `gripping`. It must be enabled
before it moves (`enable`); `setf_param("fault", 1)` makes it report an error (and stop)
until `reset_errors`. Its state goes out on the `tool_state` wire every `PERIOD`."""

from __future__ import annotations

import signal
import sys
import threading
import time
from typing import Any

import RobotRaconteur as RR
from RobotRaconteurCompanion.Util.InfoFileLoader import InfoFileLoader

from openpendant.plugins.robotraconteur.node import Node

TOOL_TYPE = "com.robotraconteur.robotics.tool.Tool"
NAMESPACE = "com.robotraconteur.robotics.tool"
STROKE = 0.085  # m
SPEED = 0.15  # m/s
PERIOD = 0.02  # s
INFO = {
    "device_info": {
        "device": {"name": "rr_sim_tool", "uuid": "5a0c9e2b-1d3f-4b6a-8e7c-2f1a0b9c8d7e"},
        "model": {"name": "RR test gripper", "uuid": "8e2d1c0b-3a4f-4b5c-9d6e-7f8a9b0c1d2e"},
        "implemented_types": [TOOL_TYPE],
    },
    "tool_type": "electric_gripper",
    "tool_capabilities": [
        "open_close_command",
        "continuous_command",
        "software_reset_errors",
        "software_enable",
    ],
    "actuation_time": STROKE / SPEED,
    "close_position": 0.0,
    "open_position": STROKE,
    "command_min": 0.0,
    "command_max": STROKE,
    "command_close": 0.0,
    "command_open": STROKE,
}


class SimTool:
    def __init__(self, node: Any, info: Any) -> None:
        self._node = node
        self._info = info
        self._flags = dict(node.GetConstants(NAMESPACE)["ToolStateFlags"])
        self._state_type = node.GetStructureType(f"{NAMESPACE}.ToolState")
        self._lock = threading.Lock()
        self._position = STROKE
        self._target = STROKE
        self._object = 0.0
        self._enabled = False
        self._fault = False
        self._seqno = 0
        self._broadcaster: Any = None
        self._running = True
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

    # RR's members -----------------------------------------------------------------------------

    @property
    def device_info(self) -> Any:
        return self._info.device_info

    @property
    def tool_info(self) -> Any:
        return self._info

    @property
    def tool_state(self) -> Any:
        return self._wire

    @tool_state.setter
    def tool_state(self, wire: Any) -> None:
        self._wire = wire
        self._broadcaster = RR.WireBroadcaster(wire)

    def open(self) -> None:
        self._command(STROKE)

    def close(self) -> None:
        self._command(0.0)

    def setf_command(self, command: float) -> None:
        if not 0.0 <= command <= STROKE:
            raise RR.InvalidArgumentException(f"command {command} is outside 0-{STROKE}")
        self._command(float(command))

    def halt(self) -> None:
        with self._lock:
            self._target = self._position

    def enable(self) -> None:
        with self._lock:
            self._enabled = True

    def disable(self) -> None:
        with self._lock:
            self._enabled = False
            self._target = self._position

    def reset_errors(self) -> None:
        with self._lock:
            self._fault = False

    def home(self) -> None:
        raise RR.NotImplementedException("this gripper needs no homing")

    def getf_param(self, name: str) -> Any:
        raise RR.InvalidArgumentException(f"no parameter {name!r}")

    def setf_param(self, name: str, value: Any) -> None:
        with self._lock:
            if name == "object":
                self._object = float(value.data[0])
            elif name == "fault":
                self._fault = bool(value.data[0])
                self._target = self._position
            else:
                raise RR.InvalidArgumentException(f"no parameter {name!r}")

    # Its fingers ----------------------------------------------------------------------------

    def _command(self, opening: float) -> None:
        with self._lock:
            if not self._enabled or self._fault:
                raise RR.InvalidOperationException("the gripper is not enabled, or has an error")
            self._target = opening

    def _loop(self) -> None:
        while self._running:
            with self._lock:
                step = max(-SPEED * PERIOD, min(SPEED * PERIOD, self._target - self._position))
                position = self._position + step
                if self._object > 0 and step < 0 and position <= self._object:
                    position = self._target = self._object  # stopped on it
                self._position = position
                state = self._state()
            if self._broadcaster is not None:
                self._broadcaster.OutValue = state
            time.sleep(PERIOD)

    def _state(self) -> Any:
        f = self._flags
        flags = 0
        if self._fault:
            flags |= f["error"]
        if self._enabled:
            flags |= f["enabled"] | (0 if self._fault else f["ready"])
        moving = abs(self._target - self._position) > 1e-9
        if moving:
            flags |= f["actuating"]
        if self._position >= STROKE - 1e-9:
            flags |= f["opened"]
        elif self._position <= 1e-9:
            flags |= f["closed"]
        else:
            flags |= f["between"]
        if not moving and self._object > 0 and abs(self._position - self._object) < 1e-9:
            flags |= f["gripping"]
        self._seqno += 1
        state = self._state_type()
        state.seqno = self._seqno
        state.tool_state_flags = flags
        state.position = self._position
        state.command = self._target
        return state


def main(port: int) -> None:
    node = Node("openpendant_rr_sim_tool", serve_port=port, localhost_only=True)
    info, _ = InfoFileLoader(node.node).LoadInfoFileFromDict(INFO, f"{NAMESPACE}.ToolInfo", "tool")
    tool = SimTool(node.node, info)
    node.node.RegisterService("tool", TOOL_TYPE, tool)
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    print("READY", flush=True)
    done.wait()
    tool._running = False
    node.close()


if __name__ == "__main__":
    main(int(sys.argv[1]))
