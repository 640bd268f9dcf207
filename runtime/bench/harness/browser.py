"""Debian's Chromium as the tests and benchmarks drive it (headless, through Playwright)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from openpendant.runtime.bench.harness.processes import Runtime

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


@contextmanager
def viewer_page(runtime: Runtime, hash_path: str) -> Iterator[Any]:
    """A tablet-sized page of the UI at `hash_path`, signed in as a viewer of `runtime`
    (Playwright must be installed: the benchmarks check first)."""
    from playwright.sync_api import sync_playwright

    cookie = runtime.session_cookie("viewer")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS
        )
        try:
            context = browser.new_context(viewport={"width": 1280, "height": 800})
            context.add_cookies([{"name": "op_session", "value": cookie, "url": runtime.url}])
            page = context.new_page()
            page.goto(f"{runtime.url}/#/{hash_path}")
            yield page
        finally:
            browser.close()
