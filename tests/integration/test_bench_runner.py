"""`openpendant bench` refuses what it does not know (test_install.py runs a benchmark from an
installed runtime and reads its JSON)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from openpendant.runtime.bench.harness.processes import child_env

# No real-time margins here: runs alongside the rest (tests/suite.py).
pytestmark = pytest.mark.concurrent


def test_unknown_benchmark_is_an_error(home: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "openpendant.runtime.cli", "bench", "--only", "warp_speed"],
        env=child_env(home),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode != 0
    assert "warp_speed" in result.stderr
