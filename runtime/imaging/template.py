"""Template matching that finds a taught pattern turned by any angle and scaled within a
range: a coarse search over angles and scales on a reduced image, then each candidate
refined at full resolution in a small window, finer in angle and scale.

A template turned on its canvas leaves corners that are not the pattern's: they are filled
with its mean grey, which adds nothing to the normalized correlation's numerator."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

MIN_COARSE_SIDE = 12  # px: the reduced template keeps at least this much to match on
REFINE_STEPS = 5  # angles and scales tried around each candidate at full resolution


@dataclass(frozen=True)
class Match:
    x: float  # the pattern's centre in the image (px)
    y: float
    angle: float  # degrees, counter-clockwise in the image as seen
    scale: float
    score: float  # normalized correlation, -1 to 1
    width: float  # the turned pattern's box (px)
    height: float


def turned(template: np.ndarray, angle: float, scale: float) -> np.ndarray:
    """The template turned by `angle` (degrees, counter-clockwise as seen) and scaled, on a
    canvas that holds it whole."""
    height, width = template.shape[:2]
    radians = np.radians(angle)
    cos, sin = abs(np.cos(radians)) * scale, abs(np.sin(radians)) * scale
    out_w = max(int(np.ceil(width * cos + height * sin)), 1)
    out_h = max(int(np.ceil(width * sin + height * cos)), 1)
    rotation = cv2.getRotationMatrix2D(((width - 1) / 2, (height - 1) / 2), angle, scale)
    rotation[0, 2] += (out_w - width) / 2
    rotation[1, 2] += (out_h - height) / 2
    fill = float(template.mean())
    return np.asarray(
        cv2.warpAffine(
            template,
            rotation,
            (out_w, out_h),
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=fill,
        )
    )


def _peaks(scores: np.ndarray, floor: float, spacing: int) -> list[tuple[float, int, int]]:
    """Local maxima above `floor`, at least `spacing` apart."""
    scores = np.nan_to_num(scores, nan=-1.0, posinf=-1.0, neginf=-1.0)
    size = max(3, spacing | 1)
    dilated = cv2.dilate(scores, np.ones((size, size), np.uint8))
    ys, xs = np.nonzero((scores >= dilated) & (scores >= floor))
    return [(float(scores[y, x]), int(x), int(y)) for y, x in zip(ys, xs, strict=True)]


def find_template(
    image: np.ndarray,
    template: np.ndarray,
    *,
    angle_step: float = 10.0,
    scales: tuple[float, float, float] = (0.9, 1.1, 0.1),
    threshold: float = 0.75,
    max_matches: int = 10,
) -> list[Match]:
    """Every place the pattern appears (best first), at most `max_matches`, none closer to
    another than half the pattern's size."""
    low, high, step = scales
    scale_list = np.arange(low, high + 1e-9, step) if step > 0 else np.array([low])
    angles = np.arange(0.0, 360.0, angle_step)
    side = min(template.shape[:2]) * float(scale_list.min())
    factor = 1
    while side / (factor * 2) >= MIN_COARSE_SIDE and factor < 8:
        factor *= 2
    small = cv2.resize(image, None, fx=1 / factor, fy=1 / factor, interpolation=cv2.INTER_AREA)
    spacing = max(int(side / factor / 2), 1)
    candidates: list[tuple[float, float, float, float, float]] = []
    for scale in scale_list:
        for angle in angles:
            pattern = turned(template, angle, scale / factor)
            if pattern.shape[0] > small.shape[0] or pattern.shape[1] > small.shape[1]:
                continue
            scores = cv2.matchTemplate(small, pattern, cv2.TM_CCOEFF_NORMED)
            for score, x, y in _peaks(scores, threshold - 0.2, spacing):
                cx = (x + (pattern.shape[1] - 1) / 2 + 0.5) * factor - 0.5
                cy = (y + (pattern.shape[0] - 1) / 2 + 0.5) * factor - 0.5
                candidates.append((score, cx, cy, angle, scale))
    candidates.sort(reverse=True)
    kept = _apart(candidates, side / 2)[: max_matches * 2]
    refined = [_refine(image, template, c, angle_step, step, factor) for c in kept]
    found = [m for m in refined if m is not None and m.score >= threshold]
    found.sort(key=lambda m: -m.score)
    apart = _apart([(m.score, m.x, m.y, m.angle, m.scale) for m in found], side / 2)
    by_place = {(m.x, m.y): m for m in found}
    return [by_place[(c[1], c[2])] for c in apart][:max_matches]


def _apart(
    candidates: list[tuple[float, float, float, float, float]], distance: float
) -> list[tuple[float, float, float, float, float]]:
    kept: list[tuple[float, float, float, float, float]] = []
    for c in candidates:
        if all(np.hypot(c[1] - k[1], c[2] - k[2]) >= distance for k in kept):
            kept.append(c)
    return kept


def _refine(
    image: np.ndarray,
    template: np.ndarray,
    candidate: tuple[float, float, float, float, float],
    angle_step: float,
    scale_step: float,
    factor: int,
) -> Match | None:
    _, cx, cy, angle, scale = candidate
    best: Match | None = None
    reach = 2 * factor + 2  # px around the coarse centre
    angles = angle + np.linspace(-angle_step / 2, angle_step / 2, REFINE_STEPS)
    scales = (
        scale + np.linspace(-scale_step / 2, scale_step / 2, REFINE_STEPS)
        if scale_step > 0
        else np.array([scale])
    )
    for s in scales:
        for a in angles:
            pattern = turned(template, float(a), float(s))
            ph, pw = pattern.shape[:2]
            left = max(round(cx - (pw - 1) / 2) - reach, 0)
            top = max(round(cy - (ph - 1) / 2) - reach, 0)
            window = image[top : top + ph + 2 * reach, left : left + pw + 2 * reach]
            if window.shape[0] < ph or window.shape[1] < pw:
                continue
            scores = np.nan_to_num(cv2.matchTemplate(window, pattern, cv2.TM_CCOEFF_NORMED), nan=-1)
            _, score, _, (x, y) = cv2.minMaxLoc(scores)
            dx, dy = _subpixel(scores, x, y)
            if best is None or score > best.score:
                best = Match(
                    x=left + x + dx + (pw - 1) / 2,
                    y=top + y + dy + (ph - 1) / 2,
                    angle=float(a) % 360.0,
                    scale=float(s),
                    score=float(score),
                    width=float(pw),
                    height=float(ph),
                )
    return best


def _subpixel(scores: np.ndarray, x: int, y: int) -> tuple[float, float]:
    """A parabola through the peak and its neighbours, each way."""

    def offset(minus: float, centre: float, plus: float) -> float:
        denominator = minus - 2 * centre + plus
        return (
            0.0
            if denominator >= 0
            else float(np.clip((minus - plus) / (2 * denominator), -0.5, 0.5))
        )

    h, w = scores.shape
    dx = offset(scores[y, x - 1], scores[y, x], scores[y, x + 1]) if 0 < x < w - 1 else 0.0
    dy = offset(scores[y - 1, x], scores[y, x], scores[y + 1, x]) if 0 < y < h - 1 else 0.0
    return dx, dy
