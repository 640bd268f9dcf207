"""The whole test suite as `make test` runs it, in two lanes at once:

- the tests that hold real-time margins (robots streaming state, links that go stale after
  200 ms, the deadman, browsers) run one at a time at normal priority, as they always did;
- beside them, first the tests marked `concurrent` (unit tests, security and API checks,
  the store, the install) on both cores at the lowest priority (nice 19), in the time the
  first lane leaves idle (it waits on processes, sockets and browsers about half of the
  time), so they never take the CPU from a real-time test; then, once those are done, the
  real-time tests marked `tolerant` (discovery, the launcher, leases: waits of seconds,
  no robot moved against a link's 200 ms margin) one at a time at nice 10, so the first
  lane still wins the CPU when both want it. The first lane runs its integration tests
  before its browser tests, so the second lane is done long before the browsers start.

Exit status: the worst of them. The second lane's reports are printed after the first's."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PYTEST = [sys.executable, "-m", "pytest"]


def _run(args: list[str], log: Path, niceness: int) -> int:
    with log.open("w") as out:
        return subprocess.call(
            [*PYTEST, *args],
            cwd=ROOT,
            stdout=out,
            stderr=subprocess.STDOUT,
            preexec_fn=lambda: os.nice(niceness),
        )


def main(extra: list[str]) -> int:
    with tempfile.TemporaryDirectory(prefix="openpendant-beside-") as scratch:
        logs = [Path(scratch) / "concurrent.log", Path(scratch) / "tolerant.log"]
        statuses: list[int] = []

        def beside() -> None:
            # Their own temporary directories and no shared cache: the lanes must not clean
            # up or overwrite each other's.
            options = ["-p", "no:cacheprovider", *extra]
            concurrent = [
                "-m",
                "concurrent",
                "-n",
                "2",
                "--dist",
                "loadfile",
                f"--basetemp={scratch}/concurrent",
            ]
            statuses.append(_run([*concurrent, *options], logs[0], 19))
            tolerant = ["-m", "tolerant", f"--basetemp={scratch}/tolerant", "--durations=10"]
            statuses.append(_run([*tolerant, *options], logs[1], 10))

        second = threading.Thread(target=beside, name="second lane")
        second.start()
        try:
            # The slowest forty, to see where the suite's time goes (docs/testing.md).
            first = subprocess.call(
                [*PYTEST, "-m", "not concurrent and not tolerant", "--durations=40", *extra],
                cwd=ROOT,
            )
        finally:
            second.join()
        for title, log in zip(("concurrent", "tolerant"), logs, strict=True):
            print(f"\n======== tests run beside them (marked {title}) ========", flush=True)
            print(log.read_text(errors="replace") if log.exists() else "(not run)", flush=True)
    print(f"real-time tests: exit {first}; beside them: exits {statuses}")
    worst = [first, *statuses] if len(statuses) == 2 else [first, 1]  # a lane that never ran
    return next((status for status in worst if status), 0)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
