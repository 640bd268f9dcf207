"""Decoding a YOLO-style detector's output: the image letterboxed into the network's square
input (its aspect kept, grey bars), each candidate box mapped back to the image, the class
score (YOLOv5: objectness times the class's; YOLOv8: the class's) thresholded, and
overlapping boxes of one class suppressed (non-maximum suppression)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

Layout = Literal["yolov5", "yolov8"]
PAD = 114  # the grey YOLO's training letterboxes with


@dataclass(frozen=True)
class Letterbox:
    scale: float
    left: int
    top: int


@dataclass(frozen=True)
class Found:
    cls: int
    score: float
    x: float  # top-left, px in the image
    y: float
    width: float
    height: float


def letterbox(image: np.ndarray, size: int) -> tuple[np.ndarray, Letterbox]:
    height, width = image.shape[:2]
    scale = min(size / height, size / width)
    new_w, new_h = round(width * scale), round(height * scale)
    resized = cv2.resize(image, (new_w, new_h), interpolation=cv2.INTER_LINEAR)
    left, top = (size - new_w) // 2, (size - new_h) // 2
    canvas = np.full((size, size, *image.shape[2:]), PAD, np.uint8)
    canvas[top : top + new_h, left : left + new_w] = resized
    return canvas, Letterbox(scale, left, top)


def decode(
    output: np.ndarray,
    layout: Layout,
    box: Letterbox,
    *,
    confidence: float,
    iou: float,
    image_size: tuple[int, int],
) -> list[Found]:
    """`output`: (1, N, 5 + C) for YOLOv5, (1, 4 + C, N) for YOLOv8 (boxes as centre x, y,
    width, height in the network's input pixels)."""
    rows = output.reshape(output.shape[-2], output.shape[-1])
    if layout == "yolov8":
        rows = rows.T
        scores = rows[:, 4:]
    else:
        scores = rows[:, 5:] * rows[:, 4:5]
    if scores.shape[1] == 0:
        return []
    classes = scores.argmax(axis=1)
    best = scores[np.arange(len(rows)), classes]
    keep = best >= confidence
    rows, classes, best = rows[keep], classes[keep], best[keep]
    width, height = image_size
    x = ((rows[:, 0] - rows[:, 2] / 2) - box.left) / box.scale
    y = ((rows[:, 1] - rows[:, 3] / 2) - box.top) / box.scale
    w, h = rows[:, 2] / box.scale, rows[:, 3] / box.scale
    x0, y0 = np.clip(x, 0, width), np.clip(y, 0, height)
    x1, y1 = np.clip(x + w, 0, width), np.clip(y + h, 0, height)
    boxes = np.stack([x0, y0, x1 - x0, y1 - y0], axis=1)
    if len(boxes) == 0:
        return []
    kept = cv2.dnn.NMSBoxesBatched(boxes.tolist(), best.tolist(), classes.tolist(), confidence, iou)
    order = sorted((int(i) for i in np.ravel(kept)), key=lambda i: -best[i])
    return [Found(int(classes[i]), float(best[i]), *(float(v) for v in boxes[i])) for i in order]
