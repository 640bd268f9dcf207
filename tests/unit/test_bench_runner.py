"""Which figures `openpendant bench --only …` reports: every figure of a benchmark named,
only the named figures of the others (a benchmark may share its name with one of its
figures, as cold_start does). A benchmark whose UI client fails reports what the others
measured and why it stopped (issue 31)."""

from __future__ import annotations

import itertools
import json
import math
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import SimpleNamespace

import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.server import ServerConnection, serve

from openpendant.runtime.bench import bench_scale, runner
from openpendant.runtime.bench.harness.processes import child_env
from openpendant.runtime.bench.runner import Figure


def fake(*names: str) -> SimpleNamespace:
    return SimpleNamespace(FIGURES=names, run=lambda: [Figure(n, 1.0, "s") for n in names])


def test_a_benchmark_named_reports_all_its_figures_a_figure_named_only_itself(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    modules = {"cold_start": fake("cold_start", "total_pss"), "jog": fake("jog_a", "jog_b")}
    monkeypatch.setattr(runner, "MODULES", tuple(modules))
    monkeypatch.setattr(runner, "load", modules.__getitem__)
    out = tmp_path / "figures.json"
    runner.main(["cold_start", "jog_b"], out)
    assert sorted(k for k in json.loads(out.read_text()) if k != "_meta") == [
        "cold_start",
        "jog_b",
        "total_pss",
    ]


@contextmanager
def device_feed(dropped: int) -> Iterator[str]:
    """A device feed on loopback as the UI clients read it: robot r0's states at 100 Hz; the
    connection accepted `dropped`-th is ended by the server with an error after one state,
    as an overloaded runtime would end it."""
    accepted = itertools.count(1)

    def feed(ws: ServerConnection) -> None:
        number = next(accepted)
        try:
            for seq in itertools.count():
                state = f'{{"seqno":{seq},"ts":{time.time()}}}'
                ws.send(f'{{"type":"state","device":"r0","ts":{time.time()},"state":{state}}}')
                if number == dropped:
                    ws.close(1011, "overloaded")
                    return
                time.sleep(0.01)
        except ConnectionClosed:
            return

    with serve(feed, "127.0.0.1", 0, max_queue=None) as server:
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        try:
            yield f"ws://127.0.0.1:{server.socket.getsockname()[1]}/"
        finally:
            server.shutdown()
            thread.join(10)


def test_a_failing_ui_client_leaves_the_others_figures_and_says_why(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The scale benchmark raised CalledProcessError and wrote no figure when one of its UI
    clients failed under load."""
    with device_feed(dropped=2) as url:
        point, failure = bench_scale.run_clients(url, 1, 0.5, child_env(tmp_path), clients=3)
    assert failure is not None and point is not None
    assert failure["exit_status"] == 1
    [failed] = failure["failed_clients"]  # which client: the one the feed dropped
    assert failed["client"] in range(3) and "1011" in failed["error"], failed
    assert "ConnectionClosedError" in failure["stderr_tail"]
    assert f"client {failed['client']} failed" in failure["stderr_tail"]
    assert point["clients_measured"] == 2 and point["failed_clients"] == [failed["client"]]
    assert point["min_rate_hz"] > 0 and math.isfinite(point["age_p99_ms"])

    stopped = bench_scale.why(failure)
    assert f"UI client {failed['client']} of 3 failed" in stopped and "exit status 1" in stopped
    measured = bench_scale.figures([point], 1, 0.5, stopped, failure)
    module = SimpleNamespace(FIGURES=bench_scale.FIGURES, run=lambda: measured)
    monkeypatch.setattr(runner, "MODULES", ("scale",))
    monkeypatch.setattr(runner, "load", {"scale": module}.__getitem__)
    out = tmp_path / "figures.json"
    assert runner.main(None, out) == 0
    written = json.loads(out.read_text())
    rate = written["scale_20_robots_min_rate"]
    assert rate["value"] == point["min_rate_hz"] and rate["meets_target"] is False
    assert rate["details"]["stopped"] == stopped
    assert rate["details"]["client_failure"]["failed_clients"] == [failed]
    assert written["scale_robots_curve"]["value"] == 0  # a curve with a failed client meets nothing
