"""One connection to a UR controller through ur-rtde: the receive, control and I/O
interfaces and the dashboard client, made together and dropped together. ur-rtde's
constructors hold Python's interpreter lock while they connect, so they are made only from
the driver's own control thread, never from the event loop."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import dashboard_client
import rtde_control
import rtde_io
import rtde_receive

from openpendant.device_drivers.ur_rtde.models import model_mismatch
from openpendant.runtime.kit.errors import RobotError

log = logging.getLogger(__name__)
_UNFREEABLE: list[Any] = []

# robot_mode, safety_mode, runtime_state (UR's RTDE guide)
POWER_OFF, IDLE, RUNNING = 3, 5, 7
NORMAL, REDUCED, PROTECTIVE_STOP = 1, 2, 3
SAFEGUARD_STOP, SYSTEM_EMERGENCY_STOP, ROBOT_EMERGENCY_STOP = 5, 6, 7
VIOLATION, FAULT = 8, 9
PLAYING = 2


@dataclass(frozen=True)
class Reading:
    """What the controller reported, once per control cycle."""

    q: list[float]
    qd: list[float]
    robot_mode: int
    safety_mode: int
    runtime_state: int
    digital_inputs: int
    digital_outputs: int
    speed_fraction: float
    timestamp: float

    @property
    def estop(self) -> bool:
        return self.safety_mode in (SYSTEM_EMERGENCY_STOP, ROBOT_EMERGENCY_STOP)

    @property
    def protective_stop(self) -> bool:
        return self.safety_mode in (PROTECTIVE_STOP, SAFEGUARD_STOP, VIOLATION, FAULT)

    @property
    def reduced(self) -> bool:
        return self.safety_mode == REDUCED

    @property
    def program_running(self) -> bool:
        return self.runtime_state == PLAYING


def write_outputs(host: str, work: Callable[[Any], object]) -> None:
    """`work(io)` on an I/O interface made for it and closed at once (in the writer's own
    process: io_writer.py says why). A long-lived one is not kept: a controller gives each
    input field to one RTDE connection at a time, so a held one would lock out every other
    writer (the arm driver's tool output and the I/O driver's outputs)."""
    io = rtde_io.RTDEIOInterface(host)
    try:
        if work(io) is False:
            raise RobotError("the controller refused the output", code="io")
    finally:
        try:
            io.disconnect()
        except RuntimeError as exc:  # the connection died meanwhile: keep it, never free it
            _UNFREEABLE.append(io)
            log.warning("an I/O connection died while in use: %s", exc)


def _disconnect(part: Any) -> None:
    try:
        part.disconnect()
    except Exception as exc:
        log.debug("closing: %s", exc)


class URLink:
    def __init__(self, host: str, frequency: float, model: str) -> None:
        """Refuses (RobotError `wrong_model`) a controller that is not the `model` arm,
        before the control script is uploaded."""
        self.host = host
        self.dashboard: Any = dashboard_client.DashboardClient(host)
        self.dashboard.connect()
        try:
            wrong = model_mismatch(
                model, self.dashboard.getRobotModel(), self.dashboard.polyscopeVersion()
            )
        except Exception:
            self.dashboard.disconnect()
            raise
        if wrong is not None:
            self.dashboard.disconnect()
            raise RobotError(wrong, code="wrong_model")
        self.receive: Any = None
        try:
            self.receive = rtde_receive.RTDEReceiveInterface(host, frequency)
            self.control: Any = rtde_control.RTDEControlInterface(host, frequency)
        except Exception:  # nothing of a half-made link stays connected
            if self.receive is not None:
                self.receive.disconnect()
            self.dashboard.disconnect()
            raise

    @property
    def connected(self) -> bool:
        return bool(self.receive.isConnected() and self.control.isConnected())

    def read(self) -> Reading:
        r = self.receive
        return Reading(
            q=list(r.getActualQ()),
            qd=list(r.getActualQd()),
            robot_mode=int(r.getRobotMode()),
            safety_mode=int(r.getSafetyMode()),
            runtime_state=int(r.getRuntimeState()),
            digital_inputs=int(r.getActualDigitalInputBits()),
            digital_outputs=int(r.getActualDigitalOutputBits()),
            speed_fraction=float(r.getTargetSpeedFraction()),
            timestamp=float(r.getTimestamp()),
        )

    def power_up(self, timeout: float = 30.0) -> None:
        """Power on and release the brakes (the controller's own sequence), until running."""
        if self.read().robot_mode == RUNNING:
            return
        self.dashboard.powerOn()
        self._until(lambda m: m in (IDLE, RUNNING), timeout, "powered on")
        self.dashboard.brakeRelease()
        self._until(lambda m: m == RUNNING, timeout, "its brakes released")

    def _until(self, done: Any, timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not done(self.read().robot_mode):
            if time.monotonic() > deadline:
                raise RobotError(f"the robot was not {what} within {timeout:.0f} s", code="power")
            time.sleep(0.05)

    def run_script(self) -> None:
        """The control script running (it stops with a protective stop, an E-stop or the
        watchdog)."""
        if not self.control.isProgramRunning() and not self.control.reuploadScript():
            raise RobotError("the control script did not start on the robot", code="script")
        # The receive interface has its own connection: wait until it, too, sees the script.
        deadline = time.monotonic() + 2.0
        while not self.read().program_running:
            if time.monotonic() > deadline:
                raise RobotError("the control script did not start on the robot", code="script")
            time.sleep(0.005)

    def unlock(self) -> None:
        """After a protective stop: close the popup and unlock (the controller refuses
        within 5 s of the stop)."""
        self.dashboard.closeSafetyPopup()
        self.dashboard.unlockProtectiveStop()
        deadline = time.monotonic() + 2.0  # until the state stream, too, says so
        while self.read().protective_stop:
            if time.monotonic() > deadline:
                raise RobotError("the protective stop was not released", code="protective_stop")
            time.sleep(0.005)

    def close(self) -> None:
        # Each of ur-rtde's disconnects sleeps 500 ms (without the interpreter lock): both at
        # once.
        closing = [
            threading.Thread(target=_disconnect, args=(part,), name="ur-close")
            for part in (self.control, self.receive)
        ]
        for thread in closing:
            thread.start()
        for thread in closing:
            thread.join()
        # Never freed: their destructors disconnect again, 500 ms each with the interpreter
        # lock held, which stopped every thread of the driver for a second at each lost
        # controller (its state stream too: the runtime's link went stale). A closed pair
        # holds tens of kB and no thread; there is one per connection lost.
        _UNFREEABLE.extend((self.control, self.receive))
        try:
            self.dashboard.disconnect()
        except Exception as exc:
            log.debug("closing the dashboard: %s", exc)
