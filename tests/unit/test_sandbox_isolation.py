"""What the kernel refuses a program's worker if the interpreter were escaped: the probes an
attacker would try first, run as native calls in a process that took the worker's own limits
in the worker's own order (`isolate_process`, then `close_off`), against the same probes in
a process that took none. On this machine (root, libseccomp) every limit is granted."""

from __future__ import annotations

import json
import subprocess
import sys

from openpendant.sandbox.protocol import ISOLATION

PROBE = r"""
import ctypes, errno, json, os, platform, socket, sys

from openpendant.sandbox.syscalls import system_call_filter
from openpendant.sandbox.worker import Limits, close_off, isolate_process

libc = ctypes.CDLL(None, use_errno=True)
KEYCTL = {"x86_64": 250, "aarch64": 219}[platform.machine()]
isolated = sys.argv[1] == "isolated"
granted = isolate_process(Limits()) + close_off(system_call_filter()) if isolated else []


def call(fn, *args):
    ctypes.set_errno(0)
    return "ran" if fn(*args) != -1 else errno.errorcode.get(ctypes.get_errno(), "?")


def attempt(fn):
    try:
        fn()
    except OSError as exc:
        return errno.errorcode.get(exc.errno, str(exc))
    return "ran"


probes = {
    "read the environment": attempt(lambda: open("/proc/self/environ", "rb").read()),
    "read init's environment": attempt(lambda: open("/proc/1/cmdline", "rb").read()),
    "ptrace": call(libc.ptrace, 0, 0, None, None),  # PTRACE_TRACEME
    "mount": call(libc.mount, b"none", b"/openpendant-no-such-dir", b"tmpfs", 0, None),
    "unshare": call(libc.unshare, 0x00020000),
    "keyctl": call(libc.syscall, KEYCTL, 0, -3, 0),  # the session keyring's id
    "raw socket": attempt(lambda: socket.socket(socket.AF_PACKET, socket.SOCK_RAW)),
    "local socket": attempt(lambda: socket.socket(socket.AF_UNIX)),
    "signal init": call(libc.kill, 1, 0),
}
sys.stdout.write(json.dumps({"granted": granted, "probes": probes}) + "\n")
sys.stdout.flush()
"""


def probe(mode: str) -> dict[str, object]:
    done = subprocess.run(
        [sys.executable, "-c", PROBE, mode], capture_output=True, text=True, timeout=60, env={}
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)  # type: ignore[no-any-return]


def test_an_escaped_program_is_refused_what_an_attacker_tries_first() -> None:
    free = probe("free")["probes"]
    # Without the limits these run (or fail only for want of the path they name).
    assert isinstance(free, dict)
    assert free["read the environment"] == "ran" and free["local socket"] == "ran"
    assert free["ptrace"] == "ran" and free["keyctl"] == "ran" and free["mount"] == "ENOENT"

    isolated = probe("isolated")
    assert isolated["granted"] == list(ISOLATION)
    probes = isolated["probes"]
    assert isinstance(probes, dict)
    assert probes == dict.fromkeys(probes, "EPERM")
