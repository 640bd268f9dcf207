"""The neural detector's networks: ONNX files in the data directory's `models/`, listed,
added from an upload (kept only once OpenCV has read it) and removed."""

from __future__ import annotations

import asyncio
import os
import re
import secrets
from pathlib import Path

import cv2

from openpendant.runtime.kit import deadline
from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.kit.uploads import MAX_MODEL_BYTES
from openpendant.runtime.vision.detectors import MODEL_FILE


def _checked(name: str) -> str:
    if not re.fullmatch(MODEL_FILE, name):
        raise InvalidValue(
            f"{name[:80]!r} is not a model file's name: letters, digits, _ . - ending in .onnx",
            code="bad_name",
        )
    return name


def _readable(path: Path) -> None:
    cv2.dnn.readNetFromONNX(str(path))


class ModelFiles:
    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def names(self) -> list[str]:
        if not self.folder.is_dir():
            return []
        return sorted(p.name for p in self.folder.glob("*.onnx") if p.is_file())

    async def add(self, name: str, data: bytes) -> list[str]:
        """Keeps `data` as the model `name` (replacing one of that name) if OpenCV reads it;
        a file it cannot read is refused and nothing changes."""
        _checked(name)
        if not data:
            raise InvalidValue("the upload is empty", code="bad_model")
        if len(data) > MAX_MODEL_BYTES:
            raise InvalidValue(f"a model is at most {MAX_MODEL_BYTES} bytes", code="too_large")
        self.folder.mkdir(parents=True, exist_ok=True)
        # Beside its place (one file system), hidden from the list until it is whole and read.
        part = self.folder / f".{name}.{secrets.token_hex(4)}.part"
        try:
            await asyncio.to_thread(part.write_bytes, data)
            try:
                await asyncio.to_thread(_readable, part)
            except cv2.error as exc:
                raise InvalidValue(
                    f"{name} is not a network OpenCV can read: {exc.msg.strip()[:200]}",
                    code="bad_model",
                ) from None
            deadline.check()  # the gateway has not given up on this upload: keep it
            os.replace(part, self.folder / name)
        finally:
            part.unlink(missing_ok=True)
        return self.names()

    def remove(self, name: str) -> list[str]:
        try:
            (self.folder / _checked(name)).unlink()
        except FileNotFoundError:
            raise NotFound(f"no model {name}", code="no_such_model") from None
        return self.names()
