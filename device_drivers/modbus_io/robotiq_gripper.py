"""A Robotiq 2F-85 or 2F-140 over Modbus (RTU on its own cable, or TCP through a gateway):
its status polled at a steady rate, every request confirmed by reading it back, and each
motion followed until the fingers stop (at the position, or on an object).

While the gripper does not answer, its position and grip are unknown (None, no object):
never the last ones read."""

from __future__ import annotations

import asyncio
import dataclasses
import time
from collections.abc import Callable

from openpendant.device_drivers.modbus_io import robotiq
from openpendant.device_drivers.modbus_io.link import ModbusLink
from openpendant.device_drivers.modbus_io.polled import Polled
from openpendant.device_drivers.modbus_io.robotiq import Profile, Request, Status
from openpendant.device_drivers.modbus_io.simulator import ModbusSimulator
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.gripper import (
    GripperDriver,
    GripperInfo,
    GripperMotion,
    GripperState,
)
from openpendant.runtime.kit.errors import InvalidValue, OpenPendantError, Unavailable

ACTIVATION_TIMEOUT = 10.0  # s; the fingers travel the whole stroke twice to find it
CHECK_PERIOD = 0.02  # s between status reads while following a motion


class GripperFault(OpenPendantError):
    status = 409
    code = "gripper_fault"


class RobotiqGripper(Polled, GripperDriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        profile: Profile,
        link: ModbusLink,
        *,
        poll_hz: float = 20.0,
        clock: Callable[[], float] = time.time,
        simulator: ModbusSimulator | None = None,
    ) -> None:
        info = GripperInfo(
            model=profile.model,
            stroke=profile.stroke,
            max_speed=profile.speed[1],
            max_force=profile.force[1],
            capabilities=["position", "object_detection"],
        )
        super().__init__(identity, info)
        self.profile, self.link, self.clock = profile, link, clock
        self.period = 1.0 / poll_hz
        self.status: Status | None = None  # None while unknown
        self.error = "not connected yet"
        self.seqno = 0
        # What a motion takes when it does not say: full speed, half the force (firm
        # enough for most parts, gentle on thin-walled ones).
        self.speed = profile.speed[1]
        self.force = (profile.force[0] + profile.force[1]) / 2
        self.sent = Request()  # the last request the gripper confirmed holding
        self.simulator = simulator

    # The device ----------------------------------------------------------------------------

    async def _read_status(self) -> Status:
        async with self.link.lock:
            words = await self.link.read("holding_register", robotiq.STATUS_ADDRESS, robotiq.WORDS)
        self._seen(Status.of(words), "")
        return Status.of(words)

    def _seen(self, status: Status | None, error: str) -> None:
        self.status, self.error = status, error
        self.seqno += 1

    async def poll_once(self) -> None:
        try:
            await self._read_status()
        except OpenPendantError as exc:
            self._seen(None, exc.message)

    async def _send(self, request: Request) -> None:
        """Write the request, then read it back: sent only if the gripper holds it."""
        words = request.words()
        async with self.link.lock:
            await self.link.write_registers("sending the request", robotiq.REQUEST_ADDRESS, words)
            held = await self.link.read("holding_register", robotiq.REQUEST_ADDRESS, robotiq.WORDS)
        if held != words:
            raise OpenPendantError(
                f"the gripper holds request {held}, not {words}", code="not_confirmed", status=502
            )
        self.sent = request

    async def _until(self, done: Callable[[Status], bool], timeout: float, what: str) -> Status:
        deadline = time.monotonic() + timeout
        while True:
            status = await self._read_status()
            if status.fault in robotiq.MAJOR_FAULTS or (status.fault and not status.activated):
                raise GripperFault(f"{what}: {robotiq.fault_text(status.fault)}")
            if done(status):
                return status
            if time.monotonic() > deadline:
                raise Unavailable(
                    f"{what} did not finish in {timeout:.0f} s", code="gripper_timeout"
                )
            await asyncio.sleep(CHECK_PERIOD)

    async def _go(self, count: int, motion: GripperMotion) -> GripperState:
        status = self.status or await self._read_status()
        if status.activation != robotiq.ACTIVE:
            raise InvalidValue(
                "activate the gripper first (Activate in the Jog panel, or the activate block)",
                code="not_activated",
            )
        speed = motion.speed or self.speed
        force = motion.force or self.force
        request = Request(
            robotiq.ACT | robotiq.GTO,
            count,
            robotiq.scaled(speed, self.profile.speed),
            robotiq.scaled(force, self.profile.force),
        )
        await self._send(request)
        travel = self.profile.stroke / max(min(speed, self.profile.speed[1]), self.profile.speed[0])
        # Done when the gripper has taken this request and its fingers stopped (there, on
        # an object, or halted by a stop).
        await self._until(
            lambda s: s.echo == count and (s.object != robotiq.MOVING or not s.going),
            travel + 2.0,
            "the motion",
        )
        return self.state()

    # The gripper interface -----------------------------------------------------------------

    async def activate(self) -> GripperState:
        await self._send(Request())  # a reset first: activation starts on rACT's rising edge
        await self._send(Request(robotiq.ACT))
        await self._until(
            lambda s: s.activation == robotiq.ACTIVE, ACTIVATION_TIMEOUT, "the activation"
        )
        return self.state()

    async def open(self, motion: GripperMotion) -> GripperState:
        return await self._go(0, motion)

    async def close(self, motion: GripperMotion) -> GripperState:
        return await self._go(255, motion)

    async def move(self, motion: GripperMotion) -> GripperState:
        if motion.position is None:
            raise InvalidValue("a move needs the position (m of opening)")
        if motion.position > self.profile.stroke:
            raise InvalidValue(f"the {self.profile.model} opens at most {self.profile.stroke} m")
        return await self._go(robotiq.width_to_count(motion.position, self.profile.stroke), motion)

    async def stop(self) -> GripperState:
        """Stop the fingers where they are (rGTO off, the rest as it was); a held part
        stays held."""
        if self.sent.action & robotiq.ACT:
            await self._send(dataclasses.replace(self.sent, action=robotiq.ACT))
        return self.state()

    def state(self) -> GripperState:
        s = self.status
        if s is None:
            return GripperState(
                seqno=self.seqno,
                ts=self.clock(),
                connected=False,
                activated=False,
                fault=self.error,
            )
        return GripperState(
            seqno=self.seqno,
            ts=self.clock(),
            connected=True,
            activated=s.activation == robotiq.ACTIVE,
            position=robotiq.count_to_width(s.position, self.profile.stroke),
            moving=s.going and s.object == robotiq.MOVING,
            object_detected=s.object in (robotiq.STOPPED_OPENING, robotiq.STOPPED_CLOSING),
            fault=robotiq.fault_text(s.fault),
        )
