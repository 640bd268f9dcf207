"""Where frames come from: a camera OpenCV opens (a USB camera by its index, an RTSP or HTTP
stream, a video file), or a folder of images replayed in name order. Each is opened, read
one frame at a time, and closed; a source that cannot be opened or read says so."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np

IMAGES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


class SourceLost(Exception):
    """The source cannot be opened or read (unplugged, stream down, file gone)."""


class Source(Protocol):
    def open(self) -> None: ...

    def read(self) -> np.ndarray: ...  # BGR or grey; raises SourceLost

    def native_fps(self) -> float: ...  # 0: unknown

    def replays(self) -> bool: ...

    def close(self) -> None: ...


class Settings(Protocol):
    width: int | None
    height: int | None
    fps: float | None
    exposure: float | None
    focus: float | None


class CaptureSource:
    """cv2.VideoCapture: a device index ("0"), a URL or a video file (replayed in a loop)."""

    def __init__(self, source: str, settings: Settings, loop: bool) -> None:
        self.source, self.settings, self.loop = source, settings, loop
        self.capture: cv2.VideoCapture | None = None

    def open(self) -> None:
        target: int | str = int(self.source) if self.source.isdigit() else self.source
        if isinstance(target, str) and "://" not in target and not Path(target).exists():
            raise SourceLost(f"{target} does not exist")
        capture = cv2.VideoCapture(target)
        if not capture.isOpened():
            capture.release()
            raise SourceLost(f"OpenCV cannot open {self.source}")
        s = self.settings
        # What the camera does not have it ignores: OpenCV then reads back its own value.
        for prop, value in (
            (cv2.CAP_PROP_FRAME_WIDTH, s.width),
            (cv2.CAP_PROP_FRAME_HEIGHT, s.height),
            (cv2.CAP_PROP_FPS, s.fps),
        ):
            if value is not None:
                capture.set(prop, float(value))
        if s.exposure is not None:
            capture.set(cv2.CAP_PROP_AUTO_EXPOSURE, 1)  # manual (V4L2's value)
            capture.set(cv2.CAP_PROP_EXPOSURE, s.exposure)
        if s.focus is not None:
            capture.set(cv2.CAP_PROP_AUTOFOCUS, 0)
            capture.set(cv2.CAP_PROP_FOCUS, s.focus)
        self.capture = capture

    def read(self) -> np.ndarray:
        if self.capture is None:
            raise SourceLost("not open")
        ok, frame = self.capture.read()
        if not ok and self.loop and self.replays():
            self.capture.set(cv2.CAP_PROP_POS_FRAMES, 0)  # a replayed file starts again
            ok, frame = self.capture.read()
        if not ok or frame is None:
            raise SourceLost(f"no frame from {self.source}")
        return np.asarray(frame)

    def replays(self) -> bool:
        """A file, read as fast as it decodes unless paced (a camera or stream paces itself)."""
        return not self.source.isdigit() and "://" not in self.source

    def native_fps(self) -> float:
        fps = self.capture.get(cv2.CAP_PROP_FPS) if self.capture is not None else 0.0
        return float(fps) if fps and np.isfinite(fps) and fps > 0 else 0.0

    def close(self) -> None:
        if self.capture is not None:
            self.capture.release()
            self.capture = None


class FolderSource:
    """The images of a folder in name order, again and again (a recorded sequence)."""

    def __init__(self, folder: Path, loop: bool) -> None:
        self.folder, self.loop = folder, loop
        self.files: list[Path] = []
        self.next = 0

    def open(self) -> None:
        if not self.folder.is_dir():
            raise SourceLost(f"{self.folder} is not a folder")
        self.files = sorted(p for p in self.folder.iterdir() if p.suffix.lower() in IMAGES)
        if not self.files:
            raise SourceLost(f"{self.folder} holds no images")
        self.next = 0

    def read(self) -> np.ndarray:
        if self.next >= len(self.files):
            if not self.loop:
                raise SourceLost(f"the last image of {self.folder} was shown")
            self.next = 0
        path = self.files[self.next]
        self.next += 1
        frame = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if frame is None:
            raise SourceLost(f"{path.name} cannot be read")
        return np.asarray(frame)

    def native_fps(self) -> float:
        return 0.0

    def replays(self) -> bool:
        return True

    def close(self) -> None:
        self.files = []


def open_source(source: str, settings: Settings, loop: bool) -> Source:
    path = Path(source)
    if "://" not in source and not source.isdigit() and path.is_dir():
        return FolderSource(path, loop)
    return CaptureSource(source, settings, loop)


def paced(last: float, fps: float) -> float:
    """How long to wait for the next frame of a replay at `fps` (live cameras pace
    themselves)."""
    return max(0.0, last + 1.0 / fps - time.monotonic()) if fps > 0 else 0.0
