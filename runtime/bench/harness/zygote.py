"""`openpendant` commands for the tests, forked from one process that has imported them.

Every runtime and driver a test starts would begin as a fresh interpreter spending about
2.6 CPU-seconds importing the web stack and the robotics core (the suite starts about 40
runtimes and as many drivers). The zygote imports them once and forks a child per request,
which runs the command line's `main` as `python -m openpendant.runtime.cli` would: with the
request's arguments, environment, working directory, niceness and standard streams. The
launcher forks its own services the same way (`runtime/launcher/supervisor.py`).

The client side (`ZygoteClient.spawn`) hands back a `Spawned`, which a test uses as it
would a `subprocess.Popen`: pid, poll, wait, send_signal, kill, returncode, stdout."""

from __future__ import annotations

import contextlib
import gc
import json
import os
import select
import selectors
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import traceback
from pathlib import Path
from typing import IO, Any, NoReturn

from openpendant.runtime.launcher.supervisor import become

ENV = "OPENPENDANT_TEST_ZYGOTE"  # "1": the harness starts `openpendant` commands from one
MAX_REQUEST = 1 << 20
CLI = "openpendant.runtime.cli"


def preload() -> None:
    """What any runtime or driver of the tests imports (the launcher's own `preload`, for
    every installed service and driver), kept out of later garbage collections."""
    from openpendant.plugins.api import resolve
    from openpendant.plugins.registry import registry
    from openpendant.runtime.services import WEBUI, services

    modules = [spec.factory for spec in (*services(), WEBUI)]
    for driver in registry().drivers.values():
        modules += [r for r in (driver.factory, driver.options, driver.routes) if r]
    modules += [
        "openpendant.runtime.drivers.run:run_driver",
        "openpendant.runtime.services:run_service",
        "openpendant.runtime.cli:main",
        "openpendant.runtime.launcher.run:run",
    ]
    for reference in modules:
        with contextlib.suppress(Exception):  # the child imports it again and says why
            resolve(reference)
    gc.collect()
    gc.freeze()


def _child(request: dict[str, Any], fds: list[int]) -> NoReturn:
    """In the forked child: become the requested command, never return."""
    try:
        from openpendant.runtime.cli import main
    except BaseException:
        traceback.print_exc()
        os._exit(1)

    def prepare() -> None:
        os.chdir(request["cwd"])
        if request["nice"]:
            os.nice(request["nice"])
        _forget_what_was_computed()

    stdio = (fds[0], fds[1], fds[2])
    become(main, request["args"], request["env"], stdio, prepare=prepare)


def _forget_what_was_computed() -> None:
    """Nothing the zygote computed (the plugin registry, settings read from its environment)
    may stand in for what the child computes from its own."""
    for name, module in list(sys.modules.items()):
        if name.startswith("openpendant.") and module is not None:
            for value in list(vars(module).values()):
                clear = getattr(value, "cache_clear", None)
                if callable(clear) and getattr(value, "__module__", None) == name:
                    clear()


def _fork(request: dict[str, Any], fds: list[int]) -> int:
    pid = os.fork()
    if pid == 0:
        _child(request, fds)
    return pid


def serve(path: str) -> None:
    """The zygote: import, then fork one child per request until its standard input ends
    (the test process is gone: not a parent-death signal, which follows the thread that
    started the zygote)."""
    preload()
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    listener.bind(path)
    listener.listen(64)
    print("ready", flush=True)
    selector = selectors.DefaultSelector()
    selector.register(listener, selectors.EVENT_READ, None)
    selector.register(sys.stdin, selectors.EVENT_READ, "stdin")
    while True:
        for key, _ in selector.select():
            if key.data == "stdin":
                if not os.read(sys.stdin.fileno(), 4096):
                    return  # its children have this process as their parent-death signal
            elif key.data is None:
                conn, _ = listener.accept()
                message, fds, _, _ = socket.recv_fds(conn, MAX_REQUEST, 3)
                try:
                    pid = _fork(json.loads(message), fds)
                finally:
                    for fd in fds:
                        os.close(fd)
                conn.send(json.dumps({"pid": pid}).encode())
                selector.register(os.pidfd_open(pid), selectors.EVENT_READ, (pid, conn))
            else:
                pid, conn = key.data
                selector.unregister(key.fd)
                os.close(key.fd)
                _, status = os.waitpid(pid, 0)
                with contextlib.suppress(OSError):  # its test is gone
                    conn.send(json.dumps({"exit": os.waitstatus_to_exitcode(status)}).encode())
                conn.close()


class Spawned:
    """A child of the zygote, used as a `subprocess.Popen` is."""

    def __init__(self, conn: socket.socket, stdout: IO[bytes]) -> None:
        self._conn = conn
        self.stdout = stdout
        self.pid: int = json.loads(conn.recv(MAX_REQUEST))["pid"]
        self.returncode: int | None = None
        self._lock = threading.Lock()

    def _collect(self, timeout: float | None) -> None:
        if self.returncode is not None:
            return
        ready, _, _ = select.select([self._conn], [], [], timeout)
        if not ready:
            return
        with self._lock:
            if self.returncode is None:
                message = self._conn.recv(MAX_REQUEST)
                # No message: the zygote itself ended, and took the child with it.
                self.returncode = json.loads(message)["exit"] if message else -signal.SIGTERM
                self._conn.close()

    def poll(self) -> int | None:
        self._collect(0.0)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        self._collect(timeout)
        if self.returncode is None:
            raise subprocess.TimeoutExpired(str(self.pid), timeout or 0.0)
        return self.returncode

    def send_signal(self, signum: int) -> None:
        if self.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, signum)

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


def _interpreter(env: dict[str, str]) -> dict[str, str]:
    """What the interpreter reads at its start (PYTHONPATH, …), which a fork cannot change."""
    return {k: v for k, v in env.items() if k.startswith("PYTHON") and k not in UNCHANGING}


UNCHANGING = {"PYTHONUNBUFFERED"}  # the zygote's own streams are unbuffered too


def _namespace() -> int:
    """This thread's network namespace."""
    return os.stat("/proc/thread-self/ns/net").st_ino


# The network the tests start in, and the zygote with them: a thread that has entered
# another (setns) gets a fresh interpreter, which starts in its network as a fork would not.
HOME_NETWORK = _namespace()


def _installed() -> tuple[tuple[str, int], ...]:
    """The import path's folders as they are now: a package installed since (pip, in a
    test) changes one, and the zygote, which imported the old set, is started afresh."""
    found = []
    for entry in sys.path:
        with contextlib.suppress(OSError):
            found.append((entry, os.stat(entry or ".").st_mtime_ns))
    return tuple(found)


class ZygoteClient:
    """The test process's zygote, started on first use."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._proc: subprocess.Popen[bytes] | None = None
        self._path = ""
        self._installed: tuple[tuple[str, int], ...] = ()
        self._interpreter: dict[str, str] = {}
        # Zygotes started afresh leave the old one idle, not ended: its children (a module's
        # runtime, still in use) end with it, by their parent-death signal.
        self._retired: list[subprocess.Popen[bytes]] = []

    def _stop(self) -> None:
        """End every zygote (and so the children each forked)."""
        for proc in [*self._retired, *([self._proc] if self._proc else [])]:
            assert proc.stdin is not None
            proc.stdin.close()
            proc.wait(10)
        self._retired.clear()
        self._proc = None

    def _start(self) -> None:
        if self._proc is not None:
            self._retired.append(self._proc)
        self._installed = _installed()
        folder = tempfile.mkdtemp(prefix="openpendant-zygote-")
        self._path = str(Path(folder) / "socket")
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        env.pop(ENV, None)
        self._interpreter = _interpreter(env)
        self._proc = subprocess.Popen(
            [sys.executable, "-m", __name__, self._path],
            env=env,
            stdout=subprocess.PIPE,
            stdin=subprocess.PIPE,  # its end, when this process ends, ends the zygote
        )
        assert self._proc.stdout is not None
        if self._proc.stdout.readline().strip() != b"ready":
            raise RuntimeError("the test zygote did not start; see its output above")

    def spawn(
        self, argv: list[str], env: dict[str, str], stderr: IO[bytes], nice: int = 0
    ) -> Spawned | None:
        """`argv` (`[python, "-m", "openpendant.runtime.cli", …]`) forked, its stdout a pipe;
        None where a fork could not be what a fresh interpreter would be (the tests do not
        ask for one, or the interpreter's own environment differs from the zygote's)."""
        if os.environ.get(ENV) != "1" or env.get(ENV) == "0":
            return None  # not for the tests, or not for this process of theirs
        if argv[:3] != [sys.executable, "-m", CLI]:
            return None
        if _namespace() != HOME_NETWORK:
            return None  # this thread is in a network of a test's own (tests/support/netns.py)
        with self._lock:
            if (
                self._proc is None
                or self._proc.poll() is not None
                or self._installed != _installed()
            ):
                self._start()
            if _interpreter(env) != self._interpreter:
                return None
        request = {"args": argv[3:], "env": env, "cwd": os.getcwd(), "nice": nice}
        read, write = os.pipe()
        nothing = os.open(os.devnull, os.O_RDONLY)
        conn = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            conn.connect(self._path)
            socket.send_fds(conn, [json.dumps(request).encode()], [nothing, write, stderr.fileno()])
        finally:
            os.close(write)
            os.close(nothing)
        return Spawned(conn, os.fdopen(read, "rb"))


ZYGOTE = ZygoteClient()


if __name__ == "__main__":
    serve(sys.argv[1])
