"""A camera frame until the Vision panel in a browser has drawn it: the simulated camera's
capture (1280x800), JPEG encoding, the driver's frame socket, the device manager's relay,
the gateway, the browser's decode and the canvas. Each frame carries when it was taken; the
panel notes when it drew it (the same machine's clock). The next frame is asked for once
the last is drawn, as on a tablet. The browser is Debian's headless Chromium through
Playwright (`make bench`); where either is missing the figures are not measured."""

from __future__ import annotations

import importlib.util
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from openpendant.runtime.bench.harness.browser import CHROMIUM, viewer_page
from openpendant.runtime.bench.harness.processes import Runtime, child_env, wait_for
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick
from openpendant.runtime.kit.settings import DeviceSpec

FIGURES = ("camera_to_ui_latency_p50", "camera_to_ui_latency_p99", "camera_to_ui_fps")
CAMERA = DeviceSpec(driver="sim-camera", name="bench-cam", options={"fps": 30, "noise": 1.0})


def _add_camera(runtime: Runtime) -> None:
    uuid = runtime.own_device(CAMERA)["uuid"]
    added = runtime.api("POST", "/devices", json={"uuid": uuid, "local_name": "camera"})
    added.raise_for_status()
    wait_for(
        lambda: runtime.api("GET", "/devices/camera").json()["status"] == "connected",
        30,
        what="the camera connected",
    )


def _measure(page: Any, seconds: float) -> tuple[list[float], float]:
    view = page.locator("op-camera-view")
    # Warmed up: the socket open, a few frames decoded and drawn.
    page.wait_for_function(
        "() => (document.querySelector('op-app')?.shadowRoot"
        "?.querySelector('op-vision-panel')?.shadowRoot"
        "?.querySelector('op-camera-view')?.frames ?? 0) >= 10",
        timeout=30_000,
    )
    start = view.evaluate("(v) => { v.latencies.length = 0; return v.frames; }")
    began = time.monotonic()
    page.wait_for_timeout(seconds * 1000)
    frames, latencies = view.evaluate("(v) => [v.frames, [...v.latencies]]")
    rate = (frames - start) / (time.monotonic() - began)
    if not latencies:
        raise RuntimeError("the Vision panel drew no frame")
    return [value * 1000 for value in latencies], rate


def run() -> list[Figure]:
    if importlib.util.find_spec("playwright") is None:
        print(
            "  camera_view: not measured: needs playwright (pip install '.[dev]')", file=sys.stderr
        )
        return []
    if not Path(CHROMIUM).is_file():
        print(f"  camera_view: not measured: needs {CHROMIUM} (Debian's chromium)", file=sys.stderr)
        return []
    seconds = 5.0 if quick() else 20.0
    with tempfile.TemporaryDirectory(prefix="openpendant-bench-camera-") as folder:
        home = Path(folder)
        devices = json.dumps([CAMERA.model_dump()])
        runtime = Runtime(home, env=child_env(home, OPENPENDANT_DEVICES=devices))
        try:
            runtime.wait_ready()
            _add_camera(runtime)
            with viewer_page(runtime, "vision") as page:
                latencies, rate = _measure(page, seconds)
        finally:
            runtime.stop()
    details = {
        "samples": len(latencies),
        "path": "sim camera capture → JPEG → driver socket → device manager → gateway → "
        "browser decode → canvas",
        "image": "1280x800 JPEG q75",
        "camera_fps_limit": CAMERA.options["fps"],
        "max_ms": max(latencies),
    }
    return [
        Figure("camera_to_ui_latency_p50", percentile(latencies, 50), "ms", details=details),
        Figure("camera_to_ui_latency_p99", percentile(latencies, 99), "ms", details=details),
        Figure("camera_to_ui_fps", rate, "fps", details=details),
    ]
