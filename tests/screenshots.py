"""Screenshots of every panel, on a tablet and a phone, in the dark and the light theme, for
docs/screenshots/ (docs/user/features.md shows them). Runs the real runtime with a simulated UR5,
waypoints, a program and an obstacle, and Debian's Chromium:

    make screenshots                      # all of them, into docs/screenshots/
    .venv/bin/python -m tests.screenshots --out /tmp/shots --panels jog --themes light
"""

from __future__ import annotations

import argparse
import contextlib
import shutil
import tempfile
from pathlib import Path

from playwright.sync_api import Page, Playwright, expect, sync_playwright

from openpendant.runtime.bench.harness.browser import CHROMIUM, CHROMIUM_ARGS
from openpendant.runtime.bench.harness.processes import Runtime, child_env
from tests.browser.conftest import PHONE, TABLET, add_robot
from tests.support.programs import PICK_AND_PLACE_WAYPOINTS, pick_and_place, teach

PANELS = ("jog", "program", "scene", "io", "devices", "system", "users")
DEVICES = {"tablet": TABLET, "phone": PHONE}
THEMES = ("dark", "light")
OUT = Path(__file__).resolve().parent.parent / "docs" / "screenshots"


def stage(runtime: Runtime) -> None:
    """A cell worth showing: a robot with waypoints, a program, an obstacle."""
    add_robot(runtime)
    teach(runtime, PICK_AND_PLACE_WAYPOINTS)
    workspace, _ = pick_and_place()
    saved = runtime.api("PUT", "/programs/pick_and_place", json={"workspace": workspace})
    assert saved.status_code == 200, saved.text
    box = {
        "type": "scene_object",
        "value": {
            "shape": "box",
            "size": [0.3, 0.4, 0.05],
            "pose": {"position": [0.45, 0.0, 0.1], "orientation": [0, 0, 0, 1]},
        },
    }
    assert runtime.api("PUT", "/variables/table", json=box).is_success


def settle(page: Page, panel: str) -> None:
    """Wait for what the panel loads: the 3D view, the blocks, the lists."""
    if panel in ("jog", "scene"):
        view = page.get_by_test_id("robot-view")
        expect(view).to_have_attribute("data-status", "ready", timeout=60_000)
    if panel == "program":
        expect(page.locator(".blocklyBlockCanvas > g").first).to_be_visible(timeout=30_000)
    if panel == "system":
        expect(page.get_by_test_id("service").first).to_be_visible(timeout=10_000)
    if panel == "users":
        expect(page.get_by_test_id("audit-entry").first).to_be_visible(timeout=10_000)
    page.wait_for_timeout(500)  # the last frame drawn


def shoot(
    runtime: Runtime,
    out: Path,
    panels: list[str],
    devices: list[str],
    themes: list[str],
    playwright: Playwright | None = None,
) -> list[Path]:
    """Each panel on each device in each theme; with the caller's `playwright`, or one of
    its own (a thread holds one at a time)."""
    made = []
    with contextlib.ExitStack() as stack:
        p = playwright or stack.enter_context(sync_playwright())
        for device in devices:
            viewport = DEVICES[device]
            for theme in themes:
                profile = tempfile.mkdtemp(prefix="op-shots-")
                context = p.chromium.launch_persistent_context(
                    profile,
                    executable_path=CHROMIUM,
                    headless=True,
                    args=CHROMIUM_ARGS,
                    viewport=viewport,
                    has_touch=True,
                    is_mobile=viewport["width"] < 600,
                )
                try:
                    context.add_cookies(
                        [
                            {
                                "name": "op_session",
                                "value": runtime.session_cookie("admin"),
                                "url": runtime.url,
                            }
                        ]
                    )
                    context.add_init_script(
                        f"localStorage.setItem('op.theme', '{theme}');"
                        "localStorage.setItem('op.holder', 'Cell 1 pendant');"
                    )
                    page = context.new_page()
                    for panel in panels:
                        page.goto(f"{runtime.url}/#/{panel}")
                        settle(page, panel)
                        path = out / f"{panel}-{device}-{theme}.png"
                        page.screenshot(path=path)
                        made.append(path)
                        print(path)
                finally:
                    context.close()
                    shutil.rmtree(profile, ignore_errors=True)
    return made


def main(argv: list[str] | None = None, playwright: Playwright | None = None) -> list[Path]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--panels", nargs="+", choices=PANELS, default=list(PANELS))
    parser.add_argument("--devices", nargs="+", choices=list(DEVICES), default=list(DEVICES))
    parser.add_argument("--themes", nargs="+", choices=THEMES, default=list(THEMES))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    home = Path(tempfile.mkdtemp(prefix="op-shots-home-"))
    runtime = Runtime(home, env=child_env(home))
    try:
        runtime.wait_ready()
        stage(runtime)
        return shoot(runtime, args.out, args.panels, args.devices, args.themes, playwright)
    finally:
        runtime.stop()
        shutil.rmtree(home, ignore_errors=True)


if __name__ == "__main__":
    main()
