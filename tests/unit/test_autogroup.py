"""A session begun below a niced process gets its niceness as its group's
(tests/support/autogroup.py: how the browser tests keep Chromium behind the real-time ones)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPOSITORY = Path(__file__).resolve().parents[2]
ENABLED = Path("/proc/sys/kernel/sched_autogroup_enabled")

SCRIPT = """
import os, subprocess
from tests.support.autogroup import nice_new_sessions
os.nice(7)
own = subprocess.Popen(["sleep", "30"])
apart = subprocess.Popen(["sleep", "30"], start_new_session=True)
try:
    print(nice_new_sessions() == [apart.pid], os.nice(0))
    print(open(f"/proc/{apart.pid}/autogroup").read().strip())
    print(open(f"/proc/{own.pid}/autogroup").read().strip())
finally:
    own.kill()
    apart.kill()
"""


@pytest.mark.skipif(
    not ENABLED.exists() or ENABLED.read_text().strip() != "1",
    reason="this kernel does not group sessions (sched_autogroup_enabled)",
)
def test_a_session_begun_below_a_niced_process_is_niced_as_it_is() -> None:
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT], cwd=REPOSITORY, capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    changed, apart, own = done.stdout.splitlines()
    only_it, niceness = changed.split()
    assert only_it == "True"
    assert apart.endswith(f" nice {niceness}"), apart
    assert own != apart  # the child in this session keeps this session's group
