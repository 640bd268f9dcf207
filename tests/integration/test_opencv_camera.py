"""The OpenCV camera driver (issue 17): `openpendant driver opencv-camera` serves a folder of
images and a video file (what a USB camera or a stream goes through too: cv2.VideoCapture)
as the standard camera; a source that goes away is a clear fault, and it comes back by
itself. (No USB camera here: the device path is OpenCV's own.)"""

from __future__ import annotations

import base64
import itertools
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from openpendant.runtime.bench.harness.processes import DriverProc, wait_for

# No real-time margins: it runs alongside the real-time tests (tests/suite.py).
pytestmark = pytest.mark.concurrent
SHADES = [20, 70, 120, 170, 220]


def picture(shade: int) -> np.ndarray:
    """A frame whose number can be read back through JPEG: one flat shade."""
    return np.full((120, 160, 3), shade, np.uint8)


def shade_of(frame: dict[str, object]) -> int:
    data = np.frombuffer(base64.b64decode(str(frame["data"])), np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE)
    assert image is not None and image.shape == (120, 160)
    return int(np.median(image))


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    frames = tmp_path / "frames"
    frames.mkdir()
    for index, shade in enumerate(SHADES):
        cv2.imwrite(str(frames / f"{index:03d}.png"), picture(shade))
    (frames / "notes.txt").write_text("not an image")
    return frames


@pytest.fixture
def camera(tmp_path: Path, folder: Path) -> Iterator[DriverProc]:
    proc = DriverProc(
        tmp_path, "opencv-camera", "cam", "--source", str(folder), "--fps", "20",
        "--reconnect", "0.2",
    )  # fmt: skip
    try:
        proc.wait_ready()
        yield proc
    finally:
        proc.stop()


def capture(camera: DriverProc, encoding: str = "jpeg") -> dict[str, object]:
    with camera.client(timeout=10) as http:
        answer = http.post("/capture", json={"encoding": encoding})
    assert answer.status_code == 200, answer.text
    frame: dict[str, object] = answer.json()
    return frame


def state(camera: DriverProc) -> dict[str, object]:
    with camera.client() as http:
        found: dict[str, object] = http.get("/state").json()
    return found


def disconnected(camera: DriverProc) -> dict[str, object] | None:
    """The state once the driver has found its source missing."""
    now = state(camera)
    return now if not now["connected"] and now["error"] != "starting" else None


def test_a_folder_of_images_is_replayed_in_order_each_capture_a_new_frame(
    camera: DriverProc,
) -> None:
    wait_for(lambda: state(camera)["connected"], 10, what="the folder opened")
    frames = [capture(camera, "png") for _ in range(8)]
    numbers = [int(str(frame["seqno"])) for frame in frames]
    # Each capture a frame taken after it was asked: a newer one every time.
    assert all(a < b for a, b in itertools.pairwise(numbers)), numbers
    assert all(float(str(b["ts"])) > float(str(a["ts"])) for a, b in itertools.pairwise(frames))
    # In name order, round and round: the n-th frame read is image (n - 1) mod 5.
    for number, frame in zip(numbers, frames, strict=True):
        assert shade_of(frame) == SHADES[(number - 1) % len(SHADES)], (number, numbers)


def test_a_source_that_goes_away_is_a_fault_and_comes_back_by_itself(
    camera: DriverProc, folder: Path
) -> None:
    wait_for(lambda: state(camera)["connected"], 10, what="the folder opened")
    hidden = folder.with_name("unplugged")
    folder.rename(hidden)
    lost = wait_for(lambda: disconnected(camera), 10, what="the folder missed")
    assert "does not exist" in str(lost["error"]) or "cannot be read" in str(lost["error"])
    with camera.client(timeout=10) as http:
        refused = http.post("/capture", json={})
    assert refused.status_code == 503
    assert refused.json()["error"]["code"] == "camera_lost"
    hidden.rename(folder)
    wait_for(lambda: state(camera)["connected"], 10, what="the folder back")
    assert shade_of(capture(camera)) in SHADES


def test_a_video_file_is_served_and_looped(tmp_path: Path) -> None:
    video = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter.fourcc(*"MJPG"), 25.0, (160, 120))
    assert writer.isOpened(), "OpenCV's wheel writes MJPG in AVI"
    for shade in SHADES:
        writer.write(picture(shade))
    writer.release()
    proc = DriverProc(tmp_path, "opencv-camera", "clip", "--source", str(video))
    try:
        proc.wait_ready()
        wait_for(lambda: state(proc)["connected"], 10, what="the video opened")
        frames = [capture(proc) for _ in range(12)]
        shades = [shade_of(frame) for frame in frames]
        # Each a frame of the clip (through MJPG and JPEG, within a few grey levels), each
        # capture a newer frame than the last, and more frames read than the clip holds.
        assert all(min(abs(s - t) for t in SHADES) <= 3 for s in shades), shades
        numbers = [int(str(frame["seqno"])) for frame in frames]
        assert all(a < b for a, b in itertools.pairwise(numbers)), numbers
        assert numbers[-1] > len(SHADES)
        info = proc.client().get("/info").json()["info"]
        assert info["fps"] == 10.0  # none asked: the replay's default shown
    finally:
        proc.stop()


def test_a_camera_that_is_not_there_is_a_clear_fault(tmp_path: Path) -> None:
    proc = DriverProc(tmp_path, "opencv-camera", "none", "--source", str(tmp_path / "nothing"))
    try:
        proc.wait_ready()
        lost = wait_for(lambda: disconnected(proc), 10, what="the camera missed")
        assert lost["connected"] is False and "does not exist" in str(lost["error"])
        with proc.client(timeout=10) as http:
            refused = http.post("/capture", json={})
        assert refused.status_code == 503 and refused.json()["error"]["code"] == "camera_lost"
    finally:
        proc.stop()
