"""A frame as the standard camera interface sends it: PNG (lossless, for calibration) or
JPEG at the asked quality, its bytes as they are (`Frame.image()` puts them in base64 for
`POST /capture`)."""

from __future__ import annotations

import cv2
import numpy as np

from openpendant.runtime.interfaces.camera import CaptureRequest, Frame
from openpendant.runtime.kit.errors import DeviceError


def encoded_frame(pixels: np.ndarray, request: CaptureRequest, seqno: int, taken: float) -> Frame:
    if request.encoding == "png":
        ok, data = cv2.imencode(".png", pixels)
    else:
        ok, data = cv2.imencode(".jpg", pixels, [cv2.IMWRITE_JPEG_QUALITY, request.quality])
    if not ok:
        raise DeviceError(f"the frame could not be encoded as {request.encoding}", status=500)
    height, width = pixels.shape[:2]
    return Frame(
        seqno=seqno,
        ts=taken,
        width=width,
        height=height,
        encoding=request.encoding,
        data=data.tobytes(),
    )
