"""Calibrating a camera through the runtime (issue 17): the vision service's guided intrinsic
session on the simulated camera, the board moved between captures as a person would move
it; the solve's progress, cancel and save; OpenCV YAML out and in; the camera placed in the
world from a board on the table. Each result is measured against the camera's ground truth.

Not `concurrent`: the camera is a device on a link that goes stale under a starved CPU."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from openpendant.runtime.bench.harness.processes import Runtime, child_env, wait_for
from openpendant.runtime.bench.harness.views import board_views, in_world
from openpendant.runtime.kit.settings import DeviceSpec
from tests.support.vision import YAML, Cam
from tests.unit.test_neural_detector import CANDIDATES, model

# 50 mm squares: from a camera a metre above, a 30 mm board's pose was up to 1.1 mm off.
CAMERA_SPEC = DeviceSpec(
    driver="sim-camera",
    name="sim-cam",
    options={"noise": 1.0, "fps": 20, "square": 0.05, "marker": 0.037},
)
BOARD = {"squares_x": 9, "squares_y": 6, "square": 0.05, "marker": 0.037, "dictionary": "5x5_100"}
SIZE = (0.45, 0.30)


@pytest.fixture(scope="module")
def cam(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cam]:
    home = tmp_path_factory.mktemp("vision")
    devices = json.dumps([CAMERA_SPEC.model_dump()])
    runtime = Runtime(home, env=child_env(home, OPENPENDANT_DEVICES=devices))
    runtime.wait_ready()
    try:
        yield Cam(runtime, CAMERA_SPEC)
    finally:
        runtime.stop()
    assert runtime.service_errors() == []


def finished(runtime: Runtime, op: dict[str, Any]) -> dict[str, Any]:
    answer = runtime.api("GET", f"/vision/operations/{op['id']}", params={"wait": 60}, timeout=70)
    assert answer.status_code == 200, answer.text
    status: dict[str, Any] = answer.json()
    assert status["state"] == "done", status
    return status


def test_a_guided_intrinsic_calibration_finds_the_true_camera(cam: Cam) -> None:
    runtime = cam.runtime
    no_board = runtime.api("POST", "/vision/intrinsic", json={"camera": "camera"})
    assert no_board.status_code == 422 and no_board.json()["error"]["code"] == "no_board"
    unknown = runtime.api("POST", "/vision/intrinsic", json={"camera": "nocam", "board": BOARD})
    assert unknown.status_code == 404, unknown.text
    started = runtime.api("POST", "/vision/intrinsic", json={"camera": "camera", "board": BOARD})
    assert started.status_code == 201, started.text
    session = started.json()
    path = f"/vision/intrinsic/{session['id']}"

    cam.put_board(None)
    empty = runtime.api("POST", f"{path}/capture", timeout=30).json()
    assert not empty["accepted"] and empty["reason"] == "no board in view"
    for pose in board_views(cam.truth["camera"], SIZE, 14):
        cam.put_board(in_world(cam.pose, pose))
        report = runtime.api("POST", f"{path}/capture", timeout=30).json()
        assert report["accepted"], report
    view = runtime.api("GET", path).json()
    assert len(view["frames"]) == 14 and view["rejected"] == 1
    assert view["coverage"]["ready"], view["coverage"]["hints"]
    assert (view["width"], view["height"]) == (1280, 800)

    solving = runtime.api("POST", f"{path}/solve")
    assert solving.status_code == 202, solving.text
    status = finished(runtime, solving.json())
    found = status["result"]
    truth = cam.truth["camera"]
    assert found["rms"] <= 0.3
    assert found["intrinsics"]["fx"] == pytest.approx(truth["fx"], rel=0.005)
    assert found["intrinsics"]["fy"] == pytest.approx(truth["fy"], rel=0.005)
    assert found["intrinsics"]["cx"] == pytest.approx(truth["cx"], abs=3.0)
    assert found["intrinsics"]["cy"] == pytest.approx(truth["cy"], abs=3.0)
    assert found["intrinsics"]["distortion"][0] == pytest.approx(truth["distortion"][0], abs=0.01)
    assert found["uncertainty"]["fx"] > 0
    solved = runtime.api("GET", path).json()
    assert all(frame["error"] is not None for frame in solved["frames"])

    # Nothing is stored until the user saves what the solve found.
    before = runtime.api("GET", "/vision/cameras/camera/calibration")
    assert before.status_code == 409 and before.json()["error"]["code"] == "not_calibrated"
    saved = runtime.api("POST", f"/vision/operations/{status['id']}/save")
    assert saved.status_code == 200, saved.text
    stored = runtime.api("GET", "/variables/calibration.camera").json()
    assert stored["type"] == "camera_calibration"
    assert stored["value"]["intrinsics"] == found["intrinsics"]
    board_setting = runtime.api("GET", "/variables/vision.board").json()
    assert board_setting["type"] == "calibration_board" and board_setting["value"]["squares_x"] == 9
    # The stored board is the setting a next session uses when none is given.
    again = runtime.api("POST", "/vision/intrinsic", json={"camera": "camera"})
    assert again.status_code == 201 and again.json()["board"] == {**BOARD, "kind": "charuco"}


def test_a_calibration_goes_out_as_opencv_yaml_and_comes_back(cam: Cam) -> None:
    runtime = cam.runtime
    stored = runtime.api("GET", "/vision/cameras/camera/calibration").json()
    exported = runtime.api("GET", "/vision/cameras/camera/calibration.yaml")
    assert exported.status_code == 200, exported.text
    assert "camera_matrix: !!opencv-matrix" in exported.text
    broken = exported.text.replace("camera_matrix", "camera_matrixx")
    refused = runtime.api(
        "PUT", "/vision/cameras/camera/calibration.yaml", content=broken.encode(), headers=YAML
    )
    assert refused.status_code == 422 and refused.json()["error"]["code"] == "bad_file"
    unchanged = runtime.api("GET", "/vision/cameras/camera/calibration").json()
    assert unchanged == stored
    imported = runtime.api(
        "PUT",
        "/vision/cameras/camera/calibration.yaml",
        content=exported.text.encode(),
        headers=YAML,
    )
    assert imported.status_code == 200, imported.text
    back = imported.json()["intrinsics"]
    assert back["fx"] == pytest.approx(stored["intrinsics"]["fx"], rel=1e-9)
    assert back["distortion"] == pytest.approx(stored["intrinsics"]["distortion"], rel=1e-9)


def test_the_camera_is_placed_in_the_world_and_a_cancelled_run_stores_nothing(cam: Cam) -> None:
    runtime = cam.runtime
    rotation = Rotation.from_euler("x", 180, degrees=True) * Rotation.from_euler(
        "z", 12, degrees=True
    )
    board = np.eye(4)
    board[:3, :3] = rotation.as_matrix()
    board[:3, 3] = [0.45, 0.0, 0.0] - board[:3, :3] @ [SIZE[0] / 2, SIZE[1] / 2, 0.0]
    on_table = {"position": board[:3, 3].tolist(), "orientation": rotation.as_quat().tolist()}
    cam.put_board(on_table)

    long_run = runtime.api(
        "POST", "/vision/extrinsic", json={"camera": "camera", "board_pose": on_table, "frames": 30}
    )
    assert long_run.status_code == 202, long_run.text
    op = long_run.json()["id"]
    wait_for(
        lambda: runtime.api("GET", f"/vision/operations/{op}").json()["progress"] > 0.05,
        30,
        what="the run under way",
    )
    cancelled = runtime.api("POST", f"/vision/operations/{op}/cancel").json()
    assert cancelled["state"] == "cancelled" and cancelled["result"] is None
    nothing = runtime.api("POST", f"/vision/operations/{op}/save")
    assert nothing.status_code == 409
    assert runtime.api("GET", "/variables/frames.camera").status_code == 404

    started = runtime.api(
        "POST", "/vision/extrinsic", json={"camera": "camera", "board_pose": on_table, "frames": 5}
    )
    assert started.status_code == 202, started.text
    status = finished(runtime, started.json())
    result = status["result"]
    assert result["frames"] == 5 and result["reprojection"] < 0.3
    position = np.array(result["pose"]["position"])
    off_mm = np.linalg.norm(position - cam.pose[:3, 3]) * 1000
    assert off_mm < 1.0, off_mm  # 0.05-0.2 mm measured
    turned = Rotation.from_quat(result["pose"]["orientation"]).as_matrix() @ cam.pose[:3, :3].T
    assert np.degrees(Rotation.from_matrix(turned).magnitude()) < 0.1
    saved = runtime.api("POST", f"/vision/operations/{status['id']}/save")
    assert saved.status_code == 200 and saved.json()["saved"] == ["frames.camera"]
    frame = runtime.api("GET", "/variables/frames.camera").json()
    assert frame["type"] == "frame"
    # As found, its quaternion normalized again by the store (the last digit may differ).
    assert frame["value"]["pose"]["position"] == pytest.approx(result["pose"]["position"])
    assert frame["value"]["pose"]["orientation"] == pytest.approx(result["pose"]["orientation"])

    no_pose = runtime.api("POST", "/vision/extrinsic", json={"camera": "camera"})
    assert no_pose.status_code == 422 and no_pose.json()["error"]["code"] == "no_board_pose"


def test_a_cameras_frames_reach_a_viewer_through_the_gateway_at_its_pace(cam: Cam) -> None:
    """The UI's live view: the camera's frames relayed by the device manager, each told when
    it was taken, the next only after the viewer drew the last; only cameras stream."""
    runtime = cam.runtime
    url = runtime.ws_url("/devices/camera/frames/ws?encoding=jpeg&quality=60")
    with connect(url, additional_headers=runtime.auth("viewer"), max_size=2**24) as ws:
        about = json.loads(ws.recv(timeout=30))
        image = ws.recv(timeout=30)
        assert isinstance(image, bytes) and image[:2] == b"\xff\xd8"
        assert (about["width"], about["height"], about["encoding"]) == (1280, 800, "jpeg")
        time.sleep(0.5)
        back = time.time()
        ws.send("drawn")
        second = json.loads(ws.recv(timeout=30))
        assert isinstance(ws.recv(timeout=30), bytes)
        assert second["seqno"] > about["seqno"] and second["ts"] >= back - 0.05
        ws.send(b"\x00")  # any message acknowledges (the service logs no error for bytes)
        assert json.loads(ws.recv(timeout=30))["seqno"] > second["seqno"]
        assert isinstance(ws.recv(timeout=30), bytes)
    with connect(
        runtime.ws_url("/devices/nocam/frames/ws"), additional_headers=runtime.auth()
    ) as ws:
        refused = json.loads(ws.recv(timeout=10))
        assert refused["type"] == "error" and refused["error"]["code"] == "device_not_found"
    with pytest.raises(InvalidStatus):  # a signed-in user's only
        connect(runtime.ws_url("/devices/camera/frames/ws"), open_timeout=5)


def test_a_network_is_uploaded_by_an_administrator_and_kept_only_if_it_reads(cam: Cam) -> None:
    """The neural detector's model as a tablet adds it: the file's bytes through the gateway
    (not JSON), read by OpenCV before it is kept; anything else refused, nothing kept."""
    runtime = cam.runtime
    raw = {"Content-Type": "application/octet-stream"}
    network = model(CANDIDATES)
    added = runtime.api("PUT", "/vision/models/parts.onnx", content=network, headers=raw)
    assert added.status_code == 200, added.text
    assert added.json() == ["parts.onnx"]
    assert runtime.api("GET", "/vision/models").json() == ["parts.onnx"]
    junk = runtime.api("PUT", "/vision/models/junk.onnx", content=b"not a network", headers=raw)
    assert junk.status_code == 422 and junk.json()["error"]["code"] == "bad_model"
    named = runtime.api("PUT", "/vision/models/..onnx.exe", content=network, headers=raw)
    assert named.status_code in (400, 422), named.text
    programmer = runtime.api(
        "PUT", "/vision/models/p.onnx", role="programmer", content=network, headers=raw
    )
    assert programmer.status_code == 403
    assert runtime.api("GET", "/vision/models").json() == ["parts.onnx"]
    assert sorted(p.name for p in (runtime.data_dir / "models").iterdir()) == ["parts.onnx"]
    assert runtime.api("DELETE", "/vision/models/parts.onnx").json() == []
    assert runtime.api("DELETE", "/vision/models/parts.onnx").status_code == 404
