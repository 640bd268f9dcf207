"""The script the docs' screenshots are made with: its own runtime and Chromium, on the
browser tests' Playwright (a thread holds one at a time)."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from playwright.sync_api import Playwright

from tests import screenshots
from tests.browser.conftest import PHONE

pytestmark = pytest.mark.browser


def png_size(path: Path) -> tuple[int, int]:
    header = path.read_bytes()[:24]
    assert header[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = struct.unpack(">II", header[16:24])
    return width, height


def test_the_screenshot_script_shoots_a_panel(tmp_path: Path, playwright: Playwright) -> None:
    made = screenshots.main(
        ["--out", str(tmp_path), "--panels", "system", "--devices", "phone", "--themes", "light"],
        playwright,
    )
    assert made == [tmp_path / "system-phone-light.png"]
    assert png_size(made[0]) == (PHONE["width"], PHONE["height"])
