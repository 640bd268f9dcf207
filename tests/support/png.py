"""Just enough PNG decoding to look at a screenshot's pixels (8-bit RGB/RGBA, not interlaced,
as Chromium writes them)."""

from __future__ import annotations

import struct
import zlib
from typing import Any

import numpy as np


def decode(data: bytes) -> np.ndarray[Any, Any]:
    """Height x width x channels array of a PNG."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, chunks, header = 8, [], b""
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos : pos + 8])
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            header = body
        elif kind == b"IDAT":
            chunks.append(body)
        pos += 12 + length
    width, height, depth, color, _, _, interlace = struct.unpack(">IIBBBBB", header)
    if depth != 8 or color not in (2, 6) or interlace:
        raise ValueError("only 8-bit RGB/RGBA, non-interlaced PNGs")
    channels = 3 if color == 2 else 4
    raw = zlib.decompress(b"".join(chunks))
    stride = width * channels
    out = np.zeros((height, stride), dtype=np.int32)
    previous = np.zeros(stride, dtype=np.int32)
    for y in range(height):
        kind = raw[y * (stride + 1)]
        line = np.frombuffer(raw, dtype=np.uint8, count=stride, offset=y * (stride + 1) + 1)
        row = line.astype(np.int32)
        if kind == 1:  # sub
            for x in range(channels, stride):
                row[x] = (row[x] + row[x - channels]) & 255
        elif kind == 2:  # up
            row = (row + previous) & 255
        elif kind == 3:  # average
            for x in range(stride):
                left = row[x - channels] if x >= channels else 0
                row[x] = (row[x] + (left + previous[x]) // 2) & 255
        elif kind == 4:  # Paeth
            for x in range(stride):
                a = row[x - channels] if x >= channels else 0
                b = previous[x]
                c = previous[x - channels] if x >= channels else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                predictor = a if pa <= pb and pa <= pc else b if pb <= pc else c
                row[x] = (row[x] + predictor) & 255
        out[y] = row
        previous = row
    return out.reshape(height, width, channels).astype(np.uint8)
