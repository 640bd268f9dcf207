"""Template matching (issue 17): a taught pattern found where it was pasted into a noisy
image, turned by any angle and scaled within the range; nothing found where it is not."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from openpendant.runtime.imaging.template import find_template, turned

PLACED = [(300.0, 250.0, 37.0, 1.0), (900.0, 500.0, 200.0, 1.08), (640.0, 650.0, 95.0, 0.93)]


def pattern() -> np.ndarray:
    """Not symmetric under any turn: a bar, a disc and a line."""
    image = np.full((80, 120), 230, np.uint8)
    cv2.rectangle(image, (10, 10), (40, 70), 30, -1)
    cv2.circle(image, (85, 40), 20, 60, -1)
    cv2.line(image, (50, 15), (110, 15), 0, 4)
    return image


def scene(placed: list[tuple[float, float, float, float]], seed: int = 0) -> np.ndarray:
    """The pattern pasted (turned, scaled, its centre at sub-pixel positions) on grey."""
    image = np.full((800, 1280), 96, np.float32)
    for x, y, angle, scale in placed:
        piece = turned(pattern(), angle, scale).astype(np.float32)
        inside = turned(np.full(pattern().shape, 255, np.uint8), angle, scale) > 128
        h, w = piece.shape
        left, top = int(x - (w - 1) / 2), int(y - (h - 1) / 2)
        shift = np.array([[1, 0, x - (w - 1) / 2 - left], [0, 1, y - (h - 1) / 2 - top]])
        shown = np.asarray(cv2.warpAffine(piece, shift, (w, h)))
        covered = np.asarray(cv2.warpAffine(inside.astype(np.float32), shift, (w, h))) > 0.5
        image[top : top + h, left : left + w][covered] = shown[covered]
    noise = np.random.default_rng(seed).normal(0, 2.0, image.shape)
    return np.clip(image + noise, 0, 255).astype(np.uint8)


def test_each_placed_pattern_is_found_where_how_turned_and_how_large() -> None:
    found = find_template(scene(PLACED), pattern(), angle_step=10, scales=(0.9, 1.1, 0.1))
    assert len(found) == 3
    for x, y, angle, scale in PLACED:
        match = min(found, key=lambda m: np.hypot(m.x - x, m.y - y))
        assert np.hypot(match.x - x, match.y - y) < 0.5
        assert abs((match.angle - angle + 180) % 360 - 180) < 1.0
        assert match.scale == pytest.approx(scale, abs=0.02)
        assert match.score > 0.9


def test_nothing_is_found_where_the_pattern_is_not() -> None:
    assert find_template(scene([]), pattern()) == []
    # Out of the scale range taught: too large to be this part.
    assert find_template(scene([(640.0, 400.0, 0.0, 1.6)]), pattern(), scales=(0.9, 1.1, 0.1)) == []


def test_at_most_the_matches_asked_for_best_first() -> None:
    found = find_template(scene(PLACED), pattern(), max_matches=2)
    assert len(found) == 2 and found[0].score >= found[1].score


def test_a_region_outside_the_image_is_a_clear_error() -> None:
    import asyncio
    import base64

    from openpendant.runtime.interfaces.detector import DetectRequest
    from openpendant.runtime.kit.errors import InvalidValue
    from openpendant.runtime.vision.detectors import DetectorConfig
    from openpendant.runtime.vision.template_detector import TemplateDetector

    ok, png = cv2.imencode(".png", pattern())
    assert ok
    config = DetectorConfig.model_validate(
        {
            "method": "template",
            "camera": "camera",
            "template": base64.b64encode(png.tobytes()).decode(),
            "region": {"x": 5000, "y": 0, "width": 100, "height": 100},
        }
    )

    async def grab() -> tuple[np.ndarray, float]:
        return scene(PLACED), 0.0

    with pytest.raises(InvalidValue, match="region lies outside"):
        asyncio.run(TemplateDetector(config, grab, None, None).detect(DetectRequest()))
