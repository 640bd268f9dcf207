"""Typed clients of the I/O block, gripper, camera and detector interfaces."""

from __future__ import annotations

from typing import ClassVar

from openpendant.runtime.clients.base import DeviceClient
from openpendant.runtime.interfaces.camera import Camera, CameraState, CaptureRequest, Image
from openpendant.runtime.interfaces.detector import (
    Detections,
    Detector,
    DetectorState,
    DetectRequest,
)
from openpendant.runtime.interfaces.gripper import Gripper, GripperMotion, GripperState
from openpendant.runtime.interfaces.io import IOBlock, IOState, SignalReading, SignalWrite


class IOClient(DeviceClient[IOState], IOBlock):
    kind: ClassVar[str] = "io"
    state_model = IOState

    async def read(self, name: str) -> SignalReading:
        return await self._call(IOBlock.read, name)

    async def write(self, name: str, command: SignalWrite) -> SignalReading:
        return await self._call(IOBlock.write, name, command)


class GripperClient(DeviceClient[GripperState], Gripper):
    kind: ClassVar[str] = "gripper"
    state_model = GripperState

    async def activate(self) -> GripperState:
        return await self._call(Gripper.activate)

    async def open(self, motion: GripperMotion) -> GripperState:
        return await self._call(Gripper.open, motion)

    async def close(self, motion: GripperMotion) -> GripperState:
        return await self._call(Gripper.close, motion)

    async def move(self, motion: GripperMotion) -> GripperState:
        return await self._call(Gripper.move, motion)

    async def stop(self) -> GripperState:
        return await self._call(Gripper.stop)


class CameraClient(DeviceClient[CameraState], Camera):
    kind: ClassVar[str] = "camera"
    state_model = CameraState

    async def capture(self, request: CaptureRequest) -> Image:
        return await self._call(Camera.capture, request)


class DetectorClient(DeviceClient[DetectorState], Detector):
    kind: ClassVar[str] = "detector"
    state_model = DetectorState

    async def detect(self, request: DetectRequest) -> Detections:
        return await self._call(Detector.detect, request)
