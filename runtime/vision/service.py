"""The vision service: guided camera calibration (intrinsic sessions, the camera's pose in
the world), long operations with progress and cancel, and calibrations as OpenCV YAML."""

from __future__ import annotations

import contextlib
import re
from collections.abc import AsyncIterator
from typing import Annotated

from fastapi import APIRouter, FastAPI, Header, Request
from fastapi.responses import PlainTextResponse

from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.interfaces.detector import DetectRequest
from openpendant.runtime.kit.app import create_app
from openpendant.runtime.kit.bodies import YAML_TEXT
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.motion.client import MotionClient
from openpendant.runtime.variable_storage.client import StorageClient
from openpendant.runtime.vision.calibration_file import MAX_FILE, from_yaml, to_yaml
from openpendant.runtime.vision.calibrations import Calibrations
from openpendant.runtime.vision.detection import Detection
from openpendant.runtime.vision.detectors import DetectorConfig, TemplateTeaching
from openpendant.runtime.vision.model_files import ModelFiles
from openpendant.runtime.vision.models import (
    CameraCalibration,
    ExtrinsicRequest,
    FrameReport,
    IntrinsicSessionView,
    IntrinsicStart,
    LocatedDetections,
    OperationSaved,
    OperationStatus,
    RobotOriginRequest,
    RobotOriginResult,
    calibration_variable,
)
from openpendant.runtime.vision.operations import Operation, Operations
from openpendant.runtime.vision.origin_run import OriginRun

LeaseToken = Annotated[str | None, Header(alias="X-Lease-Token", max_length=64)]
CAMERA = re.compile(r"^[a-z][a-z0-9_]{0,31}\Z")


def _camera(name: str) -> str:
    if not CAMERA.match(name):
        raise InvalidValue(f"{name!r} is not a device's local name", code="bad_name")
    return name


def vision_router(
    calibrations: Calibrations,
    operations: Operations,
    origin: OriginRun,
    detection: Detection,
    model_files: ModelFiles,
) -> APIRouter:
    router = APIRouter(prefix="/vision")

    @router.post("/intrinsic", status_code=201)
    async def start_intrinsic(body: IntrinsicStart) -> IntrinsicSessionView:
        """A guided intrinsic calibration of a camera with a board (the stored setting if
        none is given)."""
        return await calibrations.start_intrinsic(body.camera, body.board)

    @router.get("/intrinsic/{session_id}")
    async def session(session_id: str) -> IntrinsicSessionView:
        return calibrations.view(session_id)

    @router.post("/intrinsic/{session_id}/capture")
    async def capture(session_id: str) -> FrameReport:
        """A new frame from the camera: kept, or rejected with the reason."""
        return await calibrations.capture(session_id)

    @router.delete("/intrinsic/{session_id}/frames/{index}")
    async def drop_frame(session_id: str, index: int) -> IntrinsicSessionView:
        calibrations.session(session_id).remove(index)
        return calibrations.view(session_id)

    @router.post("/intrinsic/{session_id}/solve", status_code=202)
    async def solve(session_id: str) -> OperationStatus:
        return calibrations.solve(session_id).status()

    @router.post("/extrinsic", status_code=202)
    async def extrinsic(body: ExtrinsicRequest) -> OperationStatus:
        """The camera's pose in the world from a board lying at a known pose."""
        return (await calibrations.start_extrinsic(body)).status()

    @router.post("/robot_origin", status_code=202)
    async def robot_origin(body: RobotOriginRequest, token: LeaseToken = None) -> OperationStatus:
        """Where the robot stands in the world, from its flange tag seen at several poses:
        the robot moves, under the caller's control lease (cancel stops it)."""
        camera = await origin.prepare(body, token)
        assert token is not None  # prepare checked the lease

        async def work(op: Operation) -> RobotOriginResult:
            return await origin.run(op, body, token, camera)

        return operations.start("robot_origin", body.robot, work).status()

    @router.post("/detectors/{name}/detect")
    async def detect(name: str, body: DetectRequest) -> LocatedDetections:
        """Detect in a new image of the detector's camera."""
        return await detection.detect(_camera(name), body)

    @router.get("/models")
    async def models() -> list[str]:
        """The ONNX models in the data directory's `models/`, for a neural detector."""
        return model_files.names()

    @router.put("/models/{name}")
    async def add_model(name: str, request: Request) -> list[str]:
        """A network's ONNX file (the raw bytes) kept as `name` once OpenCV has read it."""
        return await model_files.add(name, await request.body())

    @router.delete("/models/{name}")
    async def remove_model(name: str) -> list[str]:
        return model_files.remove(name)

    @router.put("/detectors/{name}/template")
    async def teach(name: str, body: TemplateTeaching) -> DetectorConfig:
        """Teach a template detector the pattern inside a box drawn on a new camera image."""
        return await detection.teach(_camera(name), body)

    @router.get("/operations/{op_id}")
    async def operation(op_id: str, wait: float = 0.0) -> OperationStatus:
        if wait > 0:
            return (await operations.wait(op_id, min(wait, 600.0))).status()
        return operations.get(op_id).status()

    @router.post("/operations/{op_id}/cancel")
    async def cancel(op_id: str) -> OperationStatus:
        return (await operations.cancel(op_id)).status()

    @router.post("/operations/{op_id}/save")
    async def save(op_id: str) -> OperationSaved:
        """Stores what a finished calibration found (nothing is stored before)."""
        return await calibrations.save(op_id)

    @router.get("/cameras/{camera}/calibration")
    async def calibration(camera: str) -> CameraCalibration:
        return await calibrations.calibration(_camera(camera))

    @router.get("/cameras/{camera}/calibration.yaml")
    async def export(camera: str) -> PlainTextResponse:
        found = await calibrations.calibration(_camera(camera))
        return PlainTextResponse(
            to_yaml(found),
            media_type="application/x-yaml",
            headers={"Content-Disposition": f'attachment; filename="{camera}.yaml"'},
        )

    @router.put("/cameras/{camera}/calibration.yaml", openapi_extra=YAML_TEXT)
    async def import_(camera: str, request: Request) -> CameraCalibration:
        """An OpenCV YAML calibration (another tool's, or one exported before) as this
        camera's."""
        body = await request.body()
        if len(body) > MAX_FILE:
            raise InvalidValue("a calibration file is a few kilobytes, not this", code="too_large")
        try:
            text = body.decode()
        except UnicodeDecodeError:
            raise InvalidValue("a calibration file is text (UTF-8)", code="bad_file") from None
        imported = from_yaml(text, _camera(camera))
        await calibrations.storage.put(
            calibration_variable(camera), "camera_calibration", imported.model_dump(mode="json")
        )
        return imported

    return router


def build_app(settings: RuntimeSettings, urls: dict[str, str]) -> FastAPI:
    storage = StorageClient(urls["variable_storage"])
    devices = Devices(urls["device_manager"], "vision", settings.link.stale_after)
    motion = MotionClient(urls["motion"])
    operations = Operations()
    calibrations = Calibrations(devices, storage, operations)
    origin = OriginRun(devices, storage, motion, calibrations)

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        await devices.start()
        try:
            yield
        finally:
            await operations.close()
            await devices.close()
            await motion.aclose()
            await storage.aclose()

    app = create_app("vision", lifespan=lifespan)
    models = ModelFiles(settings.data_dir / "models")
    detection = Detection(storage, calibrations, models.folder)
    app.include_router(vision_router(calibrations, operations, origin, detection, models))
    return app
