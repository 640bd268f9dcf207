"""The simulated camera's `--cell`: the simulated robot whose cell it looks at (issue 32: a
name that matched no robot drew an empty table, with no warning). The camera may start before
the robot (the launcher starts every device at once), so while the robot may still be coming
up the camera says nothing; after that, it says the robot is missing in its state and refuses
frames; a robot that comes up later is still found."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from pathlib import Path

import pytest

from openpendant.device_drivers.sim_camera.driver import SimCamera
from openpendant.device_drivers.sim_camera.entry import SimCameraOptions, create
from openpendant.device_drivers.sim_cell.link import CellServer
from openpendant.device_drivers.sim_cell.world import CellSetup, Part, World
from openpendant.runtime.interfaces.camera import CaptureRequest
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.kit.errors import DeviceError

SMALL = {"width": 64, "height": 48, "fps": 60.0}


@pytest.fixture(autouse=True)
def own_data_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The cell's socket is named by the data directory: this test's own."""
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    monkeypatch.delenv("OPENPENDANT_SETTINGS_JSON", raising=False)


def camera(cell: str, cell_wait: float) -> SimCamera:
    options = SimCameraOptions.model_validate({**SMALL, "cell": cell, "cell_wait": cell_wait})
    return create("cam", "cam-uuid", options)


async def until(condition: Callable[[], bool]) -> None:
    async with asyncio.timeout(10):
        while True:
            if condition():
                return
            await asyncio.sleep(0.02)


def test_while_the_robot_may_still_come_up_the_camera_says_nothing() -> None:
    async def main() -> None:
        cam = camera("arm-starting-later", cell_wait=600)
        await cam.start()
        try:
            assert cam.state().error == ""
            image = await cam.capture(CaptureRequest(encoding="png"))
            assert image.width == 64  # the table, while the robot is on its way
        finally:
            await cam.shutdown()

    asyncio.run(main())


def test_a_cell_that_names_no_robot_is_an_error_until_that_robot_comes_up() -> None:
    box = Part(id="box", size=[0.04, 0.04, 0.04], pose=Pose(position=[0.45, 0.0, 0.02]))
    world = World(lambda: Pose(position=[0.5, 0.0, 0.3]), CellSetup(parts=[box]))

    async def main() -> None:
        cam = camera("arm-late", cell_wait=0)
        await cam.start()
        try:
            error = cam.state().error
            assert "no simulated robot named 'arm-late'" in error and "--cell" in error
            with pytest.raises(DeviceError) as refused:
                await cam.capture(CaptureRequest(encoding="png"))
            assert refused.value.code == "no_cell" and "'arm-late'" in refused.value.message
            # The robot comes up after all: found, and its cell is in the pictures.
            server = CellServer(world, "arm-late")
            await server.start()
            try:
                await until(lambda: cam.state().error == "")  # found
                await cam.capture(CaptureRequest(encoding="png"))
                assert cam.scene is not None and cam.scene["parts"][0]["id"] == "box"
            finally:
                await server.stop()
        finally:
            await cam.shutdown()

    asyncio.run(main())


def test_a_camera_without_a_cell_never_waits_for_one() -> None:
    async def main() -> None:
        cam = create("cam", "cam-uuid", SimCameraOptions.model_validate({**SMALL, "cell_wait": 0}))
        await cam.start()
        try:
            assert cam.state().error == ""
            await cam.capture(CaptureRequest(encoding="png"))
        finally:
            await cam.shutdown()

    asyncio.run(main())
