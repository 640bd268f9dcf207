"""`openpendant bench` runs a benchmark, prints its table and writes its figures as JSON."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.support.processes import child_env


def test_bench_writes_the_figures_checks_read(home: Path) -> None:
    out = home / "bench.json"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "runtime.cli",
            "bench",
            "--only",
            "discovery_time",
            "--json",
            str(out),
        ],
        env=child_env(home, OPENPENDANT_BENCH_QUICK="1"),
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert result.returncode == 0, result.stderr
    assert "discovery_time" in result.stdout
    figures = json.loads(out.read_text())
    figure = figures["discovery_time"]
    assert figure["unit"] == "s"
    assert 0 < figure["value"] < 10
    assert figure["details"]["trials"] == 3
    assert "discovery_from_process_start" not in figures  # --only names one figure


def test_unknown_benchmark_is_an_error(home: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "runtime.cli", "bench", "--only", "warp_speed"],
        env=child_env(home),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode != 0
    assert "warp_speed" in result.stderr
