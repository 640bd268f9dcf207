"""The neural detector (issue 17, must-show 3): a small ONNX model built here with the `onnx`
package (nothing downloaded) whose output is a fixed set of YOLO candidates; run through
OpenCV's DNN module by the detector, its boxes are decoded from the letterboxed input back to
the image, thresholded, and overlapping boxes of one class suppressed, for both YOLOv5's and
YOLOv8's layouts."""

from __future__ import annotations

import asyncio
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from openpendant.runtime.interfaces.detector import DetectRequest
from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.vision.detectors import DetectorConfig
from openpendant.runtime.vision.neural_detector import NeuralDetector

SIZE = 64  # the network's input side
# Candidates in the network's input pixels: centre x, y, width, height, objectness, then the
# scores of "bolt" and "nut".
CANDIDATES = np.array(
    [
        [32.0, 32.0, 20.0, 20.0, 0.9, 0.8, 0.1],  # a bolt
        [33.0, 32.0, 20.0, 20.0, 0.8, 0.9, 0.1],  # the same bolt, weaker: suppressed
        [33.0, 33.0, 18.0, 18.0, 0.9, 0.1, 0.7],  # a nut over it: another class, kept
        [10.0, 40.0, 8.0, 8.0, 0.95, 0.05, 0.9],  # a nut elsewhere
        [50.0, 40.0, 8.0, 8.0, 0.3, 0.9, 0.1],  # too unsure (0.27): dropped
    ],
    dtype=np.float32,
)


def model(candidates: np.ndarray) -> bytes:
    """A network that answers `candidates` whatever the image (its mean, times zero, is
    added so the output depends on the input as a real network's does)."""
    batch = candidates[None]
    nodes = [
        helper.make_node("ReduceMean", ["images"], ["mean"], keepdims=1),
        helper.make_node("Mul", ["mean", "zero"], ["nothing"]),
        helper.make_node("Reshape", ["nothing", "shape"], ["flat"]),
        helper.make_node("Add", ["candidates", "flat"], ["output0"]),
    ]
    graph = helper.make_graph(
        nodes,
        "fixed-candidates",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, SIZE, SIZE])],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, list(batch.shape))],
        [
            numpy_helper.from_array(batch, "candidates"),
            numpy_helper.from_array(np.zeros((1, 1, 1, 1), np.float32), "zero"),
            numpy_helper.from_array(np.array([1, 1, 1], np.int64), "shape"),
        ],
    )
    made = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    made.ir_version = 8
    onnx.checker.check_model(made)
    return bytes(made.SerializeToString())


def detector(models: Path, layout: str, image: np.ndarray) -> NeuralDetector:
    config = DetectorConfig.model_validate(
        {
            "method": "neural",
            "camera": "camera",
            "model": "parts.onnx",
            "classes": ["bolt", "nut"],
            "layout": layout,
            "input_size": SIZE,
            "threshold": 0.5,
            "iou": 0.45,
        }
    )

    async def grab() -> tuple[np.ndarray, float]:
        return image, 42.0

    return NeuralDetector(config, grab, models, None, None)


@pytest.mark.parametrize("layout", ["yolov5", "yolov8"])
def test_boxes_are_decoded_back_to_the_image_and_overlaps_suppressed(
    tmp_path: Path, layout: str
) -> None:
    candidates = CANDIDATES
    if layout == "yolov8":  # no objectness; (4 + classes, N)
        scores = CANDIDATES[:, 5:] * CANDIDATES[:, 4:5]
        candidates = np.hstack([CANDIDATES[:, :4], scores]).T.copy()
    (tmp_path / "parts.onnx").write_bytes(model(candidates))
    # A 128x64 image: letterboxed into 64x64 it is halved, with 16 px of grey above and below.
    image = np.zeros((64, 128, 3), np.uint8)
    found = asyncio.run(detector(tmp_path, layout, image).detect(DetectRequest())).detections
    assert [d.label for d in found] == ["nut", "bolt", "nut"]
    assert [round(d.confidence, 2) for d in found] == [0.85, 0.72, 0.63]
    bolt = found[1]
    # Centre (32, 32) in the input is (64, 32) in the image; 20 px there are 40 px here.
    assert (bolt.box.x, bolt.box.y, bolt.box.width, bolt.box.height) == pytest.approx(
        (44.0, 12.0, 40.0, 40.0)
    )
    assert bolt.pose is None  # no calibrated, placed camera: no pose
    only = asyncio.run(detector(tmp_path, layout, image).detect(DetectRequest(labels=["bolt"])))
    assert [d.label for d in only.detections] == ["bolt"] and only.ts == 42.0


def test_a_missing_or_broken_model_is_a_clear_error(tmp_path: Path) -> None:
    image = np.zeros((64, 64, 3), np.uint8)
    with pytest.raises(NotFound, match=r"put the \.onnx file in"):
        asyncio.run(detector(tmp_path, "yolov8", image).detect(DetectRequest()))
    (tmp_path / "parts.onnx").write_bytes(b"not a network")
    with pytest.raises(InvalidValue, match="not a model OpenCV can run"):
        asyncio.run(detector(tmp_path, "yolov8", image).detect(DetectRequest()))
