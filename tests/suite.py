"""The whole test suite as `make test` runs it, in three sessions at once:

- the tests that hold real-time margins (robots streaming state, links that go stale after
  200 ms, the deadman) run one at a time at normal priority, as they always did;
- the tests marked `concurrent` (unit tests, security and API checks, the store, the install)
  run on both cores at the lowest priority (nice 19) in the time the first session leaves
  idle (it waits on processes, sockets and browsers about half of the time), so they never
  take the CPU from a real-time test; so does the lint (ruff and mypy, as `make lint`);
- the tests marked `niced` (the browser tests: Chromium and the runtimes it drives) run one
  at a time at nice 19 too, Chromium's session included (tests/support/autogroup.py), in a
  network namespace of their own (their runtimes neither hear the others' discovery nor take
  their ports), with the links' timeouts widened. Where no namespace can be made (not root,
  no iproute2) they run in the first session instead.

Exit status: the first that failed. The other sessions' reports are printed after the
first's."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
import uuid
from collections.abc import Iterator
from pathlib import Path

from tests.support import netns

ROOT = Path(__file__).resolve().parent.parent


# What `make lint` runs: checked alongside the tests too, not before them.
LINT = "ruff check . && ruff format --check . && mypy"

# The niced session's runtimes: a link stale after 2 s without a state, not 200 ms (at nice 19
# a process can wait that long for a core; tests/integration/test_links*.py prove the defaults).
NICED_ENV = {
    "OPENPENDANT_LINK__STALE_AFTER": "2.0",
    "OPENPENDANT_LINK__DRIVER_TIMEOUT": "2.0",
}


@contextlib.contextmanager
def namespace() -> Iterator[str | None]:
    """A network namespace with its loopback up, or None where none can be made."""
    if netns.available() is not None:
        yield None
        return
    name = f"opniced{uuid.uuid4().hex[:6]}"
    netns.ip("netns", "add", name)
    try:
        netns.ip("-n", name, "link", "set", "lo", "up")
        yield name
    finally:
        subprocess.run(["ip", "netns", "del", name], check=False)


def main(extra: list[str]) -> int:
    pytest = [sys.executable, "-m", "pytest"]
    bin_dir = Path(sys.executable).parent
    with (
        tempfile.TemporaryDirectory(prefix="openpendant-concurrent-") as scratch,
        namespace() as niced_ns,
    ):
        log_path = Path(scratch) / "concurrent.log"
        lint_path = Path(scratch) / "lint.log"
        niced_path = Path(scratch) / "niced.log"
        with (
            log_path.open("w") as log,
            lint_path.open("w") as lint_log,
            niced_path.open("w") as niced_log,
        ):
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
                    # Its own temporary directories and no shared cache: the sessions
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
            niced = None
            if niced_ns is not None:
                niced = subprocess.Popen(
                    [
                        *("ip", "netns", "exec", niced_ns),
                        *pytest,
                        "-m",
                        "niced",
                        "--durations=10",
                        f"--basetemp={scratch}/niced",
                        "-p",
                        "no:cacheprovider",
                        *extra,
                    ],
                    cwd=ROOT,
                    env={**os.environ, **NICED_ENV},
                    stdout=niced_log,
                    stderr=subprocess.STDOUT,
                    preexec_fn=lambda: os.nice(19),
                )
            selected = "not concurrent" if niced is None else "not concurrent and not niced"
            try:
                # The slowest forty, to see where the suite's time goes (docs/testing.md).
                foreground = subprocess.call(
                    [*pytest, "-m", selected, "--durations=40", *extra], cwd=ROOT
                )
            finally:
                background_status = background.wait()
                lint_status = lint.wait()
                niced_status = 0 if niced is None else niced.wait()
        print("\n======== tests run alongside (marked concurrent) ========", flush=True)
        print(log_path.read_text(errors="replace"), flush=True)
        if niced is not None:
            print(f"======== tests run alongside (marked niced, in {niced_ns}) ========")
            print(niced_path.read_text(errors="replace"), flush=True)
        print(f"======== lint alongside ({LINT}) ========", flush=True)
        print(lint_path.read_text(errors="replace"), flush=True)
    print(
        f"real-time tests: exit {foreground}; concurrent tests: exit {background_status}; "
        f"niced tests: exit {niced_status if niced is not None else 'run with the real-time'}; "
        f"lint: exit {lint_status}"
    )
    return foreground or background_status or niced_status or lint_status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
