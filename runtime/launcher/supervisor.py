"""Child processes with restart on exit (exponential back-off) and per-process log files.

A child is forked from the launcher, which has imported what every service and driver
needs once (`preload`): the children share those pages copy-on-write instead of each
importing its own copy (about 30 MB of Python objects per process for the web stack alone,
more for the robotics core), and start at once. `OPENPENDANT_SPAWN=exec` starts each as a
fresh interpreter instead."""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import signal
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

log = logging.getLogger(__name__)

BACKOFF_START = 0.5
BACKOFF_MAX = 10.0
# A child that stayed up this long has recovered; its next failure starts the back-off anew.
HEALTHY_AFTER = 30.0
PR_SET_PDEATHSIG = 1


PR_SET_NAME = 15


def _die_with_parent() -> None:
    # If the launcher is killed outright, its children must not linger holding ports.
    libc = ctypes.CDLL("libc.so.6", use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def _name_process(name: str) -> None:
    """What ps, top and pgrep show for a forked child (its command line is the launcher's)."""
    libc = ctypes.CDLL("libc.so.6", use_errno=True)
    libc.prctl(PR_SET_NAME, f"op:{name}"[:15].encode())


Main = Callable[[list[str]], int]
TERMINATING = {signal.SIGINT, signal.SIGTERM}
# Held by another thread of the launcher while it holds locks a forked child would inherit
# held, with no thread left to release them (the watchdog's health probes: its HTTP
# client's, OpenSSL's, which the UI's child uses for HTTPS): a child is forked only between
# such rounds, never in the middle of one.
FORK_LOCK = threading.Lock()


class Forked:
    """A forked child, watched like a Popen (poll, wait, send_signal, kill)."""

    def __init__(self, pid: int) -> None:
        self.pid = pid
        self.returncode: int | None = None

    def poll(self) -> int | None:
        if self.returncode is None:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            if pid == self.pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if deadline is not None and time.monotonic() > deadline:
                raise subprocess.TimeoutExpired(str(self.pid), timeout or 0.0)
            time.sleep(0.01)
        assert self.returncode is not None
        return self.returncode

    def send_signal(self, signum: int) -> None:
        if self.poll() is None:
            os.kill(self.pid, signum)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


def fork_child(
    name: str,
    main: Main,
    argv: list[str],
    env: dict[str, str],
    log_path: Path,
    keep: tuple[int, ...],
) -> Forked:
    """Fork, and in the child run `main(argv)` as `python -m openpendant.runtime.cli` would,
    with `env` as its environment, its output in `log_path` and only the `keep` descriptors open."""
    for stream in (sys.stdout, sys.stderr):
        stream.flush()  # nothing buffered here is written twice
    # No signal may reach the child's copy of the launcher's handlers.
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, TERMINATING)
    with FORK_LOCK:  # released in the child too: it is a copy
        pid = os.fork()
    if pid:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
        return Forked(pid)
    try:
        for signum in TERMINATING:
            signal.signal(signum, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
        _name_process(name)
        out = os.open(log_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o600)
        nothing = os.open(os.devnull, os.O_RDONLY)
    except BaseException:
        traceback.print_exc()
        os._exit(1)
    become(main, argv, env, (nothing, out, out), keep)


def become(
    main: Main,
    argv: list[str],
    env: dict[str, str],
    stdio: tuple[int, int, int],
    keep: tuple[int, ...] = (),
    prepare: Callable[[], None] | None = None,
) -> NoReturn:
    """In a forked child: run `main(argv)` as `python -m openpendant.runtime.cli` would, with
    `env` as its environment, `stdio` as its standard streams and of the other descriptors
    only `keep` open (`prepare` runs just before `main`). Never returns: the child ends here,
    whatever happened, never back in its parent's code (the launcher's, the tests' zygote)."""
    code = 1
    try:
        _die_with_parent()
        for fd, target in zip(stdio, (0, 1, 2), strict=True):
            os.dup2(fd, target)
        for fd in _open_fds():
            if fd > 2 and fd not in keep:
                with contextlib.suppress(OSError):  # the listing's own, closed already
                    os.close(fd)
        os.environ.clear()
        os.environ.update(env)
        if prepare is not None:
            prepare()
        sys.argv = ["openpendant.runtime.cli", *argv]
        code = main(argv)
    except SystemExit as exc:
        code = 0 if exc.code is None else exc.code if isinstance(exc.code, int) else 1
    except BaseException:
        traceback.print_exc()
    finally:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(BaseException):
                stream.flush()
        os._exit(code)


def _open_fds() -> list[int]:
    return [int(fd) for fd in os.listdir("/proc/self/fd")]


@dataclass
class Child:
    name: str
    argv: list[
        str
    ]  # `python -m openpendant.runtime.cli …`: what an exec'd child runs, or a forked one
    env: dict[str, str]
    log_path: Path
    pass_fds: tuple[int, ...] = ()
    main: Main | None = None  # fork and run this with argv[3:], instead of exec'ing argv
    proc: subprocess.Popen[bytes] | Forked | None = None
    started: float = 0.0
    backoff: float = BACKOFF_START
    restart_at: float | None = None
    restarts: int = 0
    exit_codes: list[int] = field(default_factory=list)

    def spawn(self) -> None:
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        if self.main is not None:
            self.proc = fork_child(
                self.name, self.main, self.argv[3:], self.env, self.log_path, self.pass_fds
            )
        else:
            with self.log_path.open("ab") as out:
                self.proc = subprocess.Popen(
                    self.argv,
                    env=self.env,
                    stdout=out,
                    stderr=subprocess.STDOUT,
                    stdin=subprocess.DEVNULL,
                    pass_fds=self.pass_fds,
                    preexec_fn=_die_with_parent,
                )
        self.started = time.monotonic()
        self.restart_at = None

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None


class Supervisor:
    def __init__(
        self, healthy_after: float = HEALTHY_AFTER, backoff_start: float = BACKOFF_START
    ) -> None:
        self.children: list[Child] = []
        self.stopping = False
        self.healthy_after = healthy_after
        self.backoff_start = backoff_start

    def add(self, child: Child) -> Child:
        self.children.append(child)
        child.backoff = self.backoff_start
        child.spawn()
        return child

    def poll(self) -> None:
        """Restart children that exited; called often by the launcher's main loop."""
        now = time.monotonic()
        for child in self.children:
            if self.stopping or child.proc is None:
                continue
            code = child.proc.poll()
            if code is None:
                if now - child.started > self.healthy_after:
                    child.backoff = self.backoff_start
                continue
            if child.restart_at is None:
                child.exit_codes.append(code)
                child.restart_at = now + child.backoff
                log.warning(
                    "%s exited with code %s; restarting in %.1f s (log: %s)",
                    child.name,
                    code,
                    child.backoff,
                    child.log_path,
                )
                child.backoff = min(child.backoff * 2, BACKOFF_MAX)
            elif now >= child.restart_at:
                child.restarts += 1
                child.spawn()

    def stop_all(self, timeout: float = 5.0) -> None:
        self.stopping = True
        for child in reversed(self.children):
            if child.running and child.proc is not None:
                child.proc.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + timeout
        for child in self.children:
            if child.proc is None:
                continue
            try:
                child.proc.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                log.warning("%s did not stop in time; killing it", child.name)
                child.proc.kill()
                child.proc.wait()

    def pids(self) -> list[int]:
        return [c.proc.pid for c in self.children if c.proc is not None and c.running]


def process_env(extra: dict[str, str]) -> dict[str, str]:
    env = dict(os.environ)
    env.update(extra)
    env["PYTHONUNBUFFERED"] = "1"
    return env
