"""The vision service's calibrations: guided intrinsic sessions on a camera, the camera's
pose in the world from a board at a known pose, and saving what they found as variables
(`calibration.<camera>`, `frames.<camera>`, the board setting `vision.board`)."""

from __future__ import annotations

import asyncio
import base64
import itertools
from collections import OrderedDict

import cv2
import numpy as np

from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.clients.kinds import CameraClient
from openpendant.runtime.imaging.boards import Board, BoardSpec, NotSeen
from openpendant.runtime.interfaces.camera import CaptureRequest, Image
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.interfaces.variables import Frame
from openpendant.runtime.kit.errors import Conflict, DeviceError, InvalidValue, NotFound
from openpendant.runtime.variable_storage.client import StorageClient
from openpendant.runtime.vision.extrinsics import average, board_in_camera, camera_in_world
from openpendant.runtime.vision.intrinsics import MIN_FRAMES, IntrinsicSession
from openpendant.runtime.vision.models import (
    CameraCalibration,
    ExtrinsicRequest,
    ExtrinsicResult,
    FrameReport,
    IntrinsicSessionView,
    OperationSaved,
    RobotOriginResult,
    calibration_variable,
)
from openpendant.runtime.vision.operations import Operation, Operations
from openpendant.runtime.vision.transforms import matrix_of, pose_of

BOARD_SETTING = "vision.board"
KEEP_SESSIONS = 8


def frame_variable(name: str) -> str:
    return f"frames.{name}"


def decode(image: Image, colour: bool = False) -> np.ndarray:
    data = np.frombuffer(base64.b64decode(image.data), np.uint8)
    pixels = cv2.imdecode(data, cv2.IMREAD_COLOR if colour else cv2.IMREAD_GRAYSCALE)
    if pixels is None:
        raise DeviceError(f"the camera sent an image that is not a {image.encoding}")
    return np.asarray(pixels)


class Calibrations:
    def __init__(self, devices: Devices, storage: StorageClient, operations: Operations) -> None:
        self.devices, self.storage, self.operations = devices, storage, operations
        self.sessions: OrderedDict[str, IntrinsicSession] = OrderedDict()
        self._ids = itertools.count(1)

    # Shared ---------------------------------------------------------------------------------

    async def board(self, given: BoardSpec | None) -> BoardSpec:
        if given is not None:
            return given
        try:
            stored = await self.storage.get(BOARD_SETTING)
        except NotFound:
            raise InvalidValue(
                "say which board is used (squares, sizes, dictionary): no board is set yet",
                code="no_board",
            ) from None
        return BoardSpec.model_validate(stored.value)

    async def grab(self, camera: str, colour: bool = False) -> tuple[np.ndarray, float]:
        """A new frame from an added camera (lossless; grey unless `colour`) and when it was
        taken."""
        client = await self.devices.client(camera, "camera")
        assert isinstance(client, CameraClient)
        image = await client.capture(CaptureRequest(encoding="png"))
        return await asyncio.to_thread(decode, image, colour), image.ts

    async def calibration(self, camera: str) -> CameraCalibration:
        try:
            stored = await self.storage.get(calibration_variable(camera))
        except NotFound:
            raise Conflict(
                f"{camera} has no intrinsic calibration yet: calibrate it or import one",
                code="not_calibrated",
            ) from None
        return CameraCalibration.model_validate(stored.value)

    async def camera_pose(self, camera: str) -> np.ndarray | None:
        """Where the camera stands in the world (`frames.<camera>`), None if not placed."""
        try:
            stored = await self.storage.get(frame_variable(camera))
        except NotFound:
            return None
        if stored.type != "frame":
            raise Conflict(f"{stored.name} is a {stored.type}, not a frame", code="bad_frame")
        frame = Frame.model_validate(stored.value)
        if frame.parent != "world":
            raise Conflict(
                f"{stored.name} is given in {frame.parent}: place the camera in the world",
                code="bad_frame",
            )
        return matrix_of(frame.pose)

    # Intrinsic ------------------------------------------------------------------------------

    async def start_intrinsic(self, camera: str, board: BoardSpec | None) -> IntrinsicSessionView:
        spec = await self.board(board)
        await self.devices.entry(camera, "camera")
        session_id = f"intrinsic-{next(self._ids)}"
        self.sessions[session_id] = IntrinsicSession(camera, Board(spec))
        while len(self.sessions) > KEEP_SESSIONS:
            self.sessions.popitem(last=False)
        return self.view(session_id)

    def session(self, session_id: str) -> IntrinsicSession:
        session = self.sessions.get(session_id)
        if session is None:
            raise NotFound(f"no calibration session {session_id!r}", code="no_such_session")
        return session

    def view(
        self, session_id: str, result: CameraCalibration | None = None
    ) -> IntrinsicSessionView:
        session = self.session(session_id)
        width, height = session.size or (None, None)
        return IntrinsicSessionView(
            id=session_id,
            camera=session.camera,
            board=session.board.spec,
            width=width,
            height=height,
            frames=session.frame_views(),
            rejected=session.rejected,
            coverage=session.coverage(),
            min_frames=MIN_FRAMES,
            result=result,
        )

    async def capture(self, session_id: str) -> FrameReport:
        session = self.session(session_id)
        gray, taken = await self.grab(session.camera)
        return await asyncio.to_thread(session.add, gray, taken)

    def solve(self, session_id: str) -> Operation:
        session = self.session(session_id)

        async def work(op: Operation) -> CameraCalibration:
            solution = await asyncio.to_thread(session.solve, op.report)
            return solution.calibration

        return self.operations.start("intrinsic", session.camera, work)

    # Extrinsic ------------------------------------------------------------------------------

    async def board_pose(self, request: ExtrinsicRequest) -> np.ndarray:
        if (request.board_pose is None) == (request.board_variable is None):
            raise InvalidValue(
                "give the board's pose in the world, or a stored frame or pose (not both)",
                code="no_board_pose",
            )
        if request.board_pose is not None:
            return matrix_of(request.board_pose)
        assert request.board_variable is not None
        stored = await self.storage.get(request.board_variable)
        if stored.type == "frame":
            frame = Frame.model_validate(stored.value)
            if frame.parent != "world":
                raise InvalidValue(f"{stored.name} is in {frame.parent}, not in the world")
            return matrix_of(frame.pose)
        if stored.type == "pose":
            return matrix_of(Pose.model_validate(stored.value))
        raise InvalidValue(f"{stored.name} is a {stored.type}, not a frame or a pose")

    async def start_extrinsic(self, request: ExtrinsicRequest) -> Operation:
        spec = await self.board(request.board)
        if spec.kind != "charuco":
            raise InvalidValue(
                "a chessboard looks the same turned round: use a ChArUco board to place the camera",
                code="board_ambiguous",
            )
        calibration = await self.calibration(request.camera)
        board_in_world = await self.board_pose(request)
        await self.devices.entry(request.camera, "camera")
        board = Board(spec)

        async def work(op: Operation) -> ExtrinsicResult:
            poses, errors = [], []
            for index in range(request.frames):
                op.report(index / (request.frames + 1), f"frame {index + 1} of {request.frames}")
                gray, _ = await self.grab(request.camera)
                if gray.shape[::-1] != (
                    calibration.intrinsics.width,
                    calibration.intrinsics.height,
                ):
                    raise InvalidValue("the camera's images are not the size it was calibrated at")
                try:
                    view = await asyncio.to_thread(board.find, gray)
                except NotSeen as exc:
                    raise InvalidValue(f"frame {index + 1}: {exc}", code="board_not_seen") from None
                found = board_in_camera(view, calibration.intrinsics)
                poses.append(camera_in_world(board_in_world, found.matrix))
                errors.append(found.error)
            mean = average(poses)
            return ExtrinsicResult(
                camera=request.camera,
                pose=pose_of(mean.matrix),
                frames=len(poses),
                reprojection=float(np.sqrt(np.mean(np.square(errors)))),
                spread_mm=mean.spread_m * 1000,
                spread_deg=mean.spread_deg,
            )

        return self.operations.start("extrinsic", request.camera, work)

    # Saving ---------------------------------------------------------------------------------

    async def save(self, op_id: str) -> OperationSaved:
        """Stores what a finished operation found; returns the variables written."""
        op = self.operations.finished(op_id)
        result = op.result
        if isinstance(result, CameraCalibration):
            name = calibration_variable(result.camera)
            await self.storage.put(name, "camera_calibration", result.model_dump(mode="json"))
            if result.board is not None:
                await self.storage.put(
                    BOARD_SETTING, "calibration_board", result.board.model_dump()
                )
            saved = [name]
        elif isinstance(result, ExtrinsicResult | RobotOriginResult):
            subject, pose = (
                (result.camera, result.pose)
                if isinstance(result, ExtrinsicResult)
                else (result.robot, result.base)
            )
            name = frame_variable(subject)
            frame = Frame(pose=pose)
            await self.storage.put(name, "frame", frame.model_dump(mode="json"))
            saved = [name]
        else:  # pragma: no cover - every operation kind is handled above
            raise InvalidValue(f"{op_id} has nothing to save")
        op.saved = True
        return OperationSaved(operation=op_id, saved=saved)
