"""An input changing on a simulated Modbus I/O block until the I/O panel in a browser shows
it: the block's poll, the device manager, the UI's device feed and the panel's redraw, as on
a tablet. The block is polled at 100 Hz (`--poll-hz`, what a Modbus TCP block on a LAN
takes): at the default 20 Hz the wait for the next poll alone can be 50 ms. The browser is
Debian's headless Chromium through Playwright, which the dev extras install (`make bench`);
where either is missing the figures are not measured and the run says so."""

from __future__ import annotations

import importlib.util
import random
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

from openpendant.runtime.bench.harness.browser import CHROMIUM, viewer_page
from openpendant.runtime.bench.harness.processes import DriverProc, Runtime, child_env, wait_for
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick

FIGURES = ("io_panel_input_to_ui_p50", "io_panel_input_to_ui_p99")
TARGET_P99 = 50.0  # ms
SIGNAL = "part_present"
POLL_HZ = 100

# When the panel's cell for the signal changes, in the page's clock (the machine's).
WATCH = """(cell) => {
  window.__seen = [];
  new MutationObserver(() => window.__seen.push(
      [cell.getAttribute('data-value'), performance.timeOrigin + performance.now()]))
    .observe(cell, {attributes: true, attributeFilter: ['data-value']});
}"""


def _measure(page: Any, block: str, count: int) -> list[float]:
    test_id = f"signal-cell_io-{SIGNAL}"
    cell = page.get_by_test_id(test_id)
    cell.and_(page.locator('[data-value="false"]')).wait_for(timeout=20_000)
    cell.evaluate(WATCH)  # the panel's own element (inside its component's shadow root)
    rng = random.Random(1)
    latencies = []
    with httpx.Client(timeout=5) as client:
        for i in range(count):
            value = i % 2 == 0
            time.sleep(rng.uniform(0.05, 0.15))  # changes at any phase of the poll
            changed_at = time.time() * 1000
            client.put(f"{block}/sim/signals/{SIGNAL}", json={"value": value})
            page.wait_for_function("(n) => window.__seen.length > n", arg=i, timeout=10_000)
            shown, shown_at = page.evaluate("(n) => window.__seen[n]", i)
            if shown != str(value).lower():
                raise RuntimeError(f"the panel showed {shown} for {value}")
            latencies.append(shown_at - changed_at)
    return latencies


def run() -> list[Figure]:
    if importlib.util.find_spec("playwright") is None:
        print("  io_panel: not measured: needs playwright (pip install '.[dev]')", file=sys.stderr)
        return []
    if not Path(CHROMIUM).is_file():
        print(f"  io_panel: not measured: needs {CHROMIUM} (Debian's chromium)", file=sys.stderr)
        return []
    count = 20 if quick() else 100
    with tempfile.TemporaryDirectory(prefix="openpendant-bench-io-") as folder:
        home = Path(folder)
        runtime = Runtime(home, env=child_env(home))
        block_proc = None
        try:
            runtime.wait_ready()
            block_proc = DriverProc(
                home, "modbus-io", "cell-io", "--simulate", "--poll-hz", f"{POLL_HZ:g}"
            )
            block = block_proc.wait_ready()
            added = runtime.api("POST", "/devices", json={"url": block, "local_name": "cell_io"})
            added.raise_for_status()
            wait_for(
                lambda: runtime.api("GET", "/devices/cell_io").json()["status"] == "connected",
                15,
                what="the I/O block connected",
            )
            with viewer_page(runtime, "io") as page:
                latencies = _measure(page, block, count)
        finally:
            if block_proc is not None:
                block_proc.stop()
            runtime.stop()
    p99 = percentile(latencies, 99)
    details = {
        "samples": count,
        "path": "simulator input → Modbus poll → device manager → UI feed → panel",
        "poll_hz": POLL_HZ,
        "max_ms": max(latencies),
    }
    return [
        Figure("io_panel_input_to_ui_p50", percentile(latencies, 50), "ms", details=details),
        Figure(
            "io_panel_input_to_ui_p99",
            p99,
            "ms",
            target=f"≤ {TARGET_P99:g}",
            meets_target=p99 <= TARGET_P99,
            details=details,
        ),
    ]
