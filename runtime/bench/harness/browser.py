"""Debian's Chromium as the tests and benchmarks drive it (headless, through Playwright)."""

from __future__ import annotations

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--no-first-run",
    "--disable-sync",
    # No GPU here: WebGL (the 3D view) renders in software. Tablets use their GPU.
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]
