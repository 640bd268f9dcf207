"""The whole test suite as `make test` runs it, in two sessions at once:

- the tests that hold real-time margins (robots streaming state, links that go stale after
  200 ms, the deadman, browsers) run one at a time at normal priority, as they always did;
- the tests marked `concurrent` (unit tests, security and API checks, the store, the install)
  run on both cores at the lowest priority (nice 19) in the time the first session leaves
  idle (it waits on processes, sockets and browsers about half of the time), so they never
  take the CPU from a real-time test; so does the lint (ruff and mypy, as `make lint`).

Exit status: the first that failed. The concurrent session's report is printed after the
other's."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


# What `make lint` runs: checked alongside the tests too, not before them.
LINT = "ruff check . && ruff format --check . && mypy"


def main(extra: list[str]) -> int:
    pytest = [sys.executable, "-m", "pytest"]
    bin_dir = Path(sys.executable).parent
    with tempfile.TemporaryDirectory(prefix="openpendant-concurrent-") as scratch:
        log_path = Path(scratch) / "concurrent.log"
        lint_path = Path(scratch) / "lint.log"
        with log_path.open("w") as log, lint_path.open("w") as lint_log:
            lint = subprocess.Popen(
                ["sh", "-c", LINT],
                cwd=ROOT,
                env={**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}"},
                stdout=lint_log,
                stderr=subprocess.STDOUT,
                preexec_fn=lambda: os.nice(19),
            )
            background = subprocess.Popen(
                [
                    *pytest,
                    "-m",
                    "concurrent",
                    "-n",
                    "2",
                    "--dist",
                    "loadfile",
                    # Its own temporary directories and no shared cache: the two sessions
                    # must not clean up or overwrite each other's.
                    f"--basetemp={scratch}/tmp",
                    "-p",
                    "no:cacheprovider",
                    *extra,
                ],
                cwd=ROOT,
                stdout=log,
                stderr=subprocess.STDOUT,
                preexec_fn=lambda: os.nice(19),
            )
            try:
                # The slowest forty, to see where the suite's time goes (docs/testing.md).
                foreground = subprocess.call(
                    [*pytest, "-m", "not concurrent", "--durations=40", *extra], cwd=ROOT
                )
            finally:
                background_status = background.wait()
                lint_status = lint.wait()
        print("\n======== tests run alongside (marked concurrent) ========", flush=True)
        print(log_path.read_text(errors="replace"), flush=True)
        print(f"======== lint alongside ({LINT}) ========", flush=True)
        print(lint_path.read_text(errors="replace"), flush=True)
    print(
        f"real-time tests: exit {foreground}; concurrent tests: exit {background_status}; "
        f"lint: exit {lint_status}"
    )
    return foreground or background_status or lint_status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
