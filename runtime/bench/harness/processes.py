"""Real processes on loopback for the integration, browser and benchmark suites."""

from __future__ import annotations

import contextlib
import json
import os
import queue
import signal
import socket
import ssl
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import httpx

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.setup import auth_path, create_token
from openpendant.runtime.auth.store import AuthStore
from openpendant.runtime.bench.harness.zygote import ZYGOTE, Spawned
from openpendant.runtime.kit.client import CLIENT_TLS
from openpendant.runtime.kit.device_auth import BOOT_HEADER, DeviceAuth, known_secret, sign
from openpendant.runtime.kit.device_auth import HEADER as DEVICE_AUTH
from openpendant.runtime.kit.internal import FILE as INTERNAL_FILE
from openpendant.runtime.kit.internal import HEADER as INTERNAL_HEADER
from openpendant.runtime.kit.settings import DeviceSpec, default_devices
from openpendant.runtime.kit.tls import CA_CERT, TLS_DIR
from openpendant.runtime.launcher.run import device_uuid

T = TypeVar("T")

# Joints that changed by less than this (rad) did not move: live floating-point state is never
# compared exactly (a halted simulator still settles in the last digits).
STILL = 1e-6

# Every process a test starts does discovery on loopback only (DESIGN.md §5, §8).
LOOPBACK_ENV = {"OPENPENDANT_DISCOVERY__INTERFACES": '["127.0.0.1"]'}
# Of the default cell, the runtimes of tests and benchmarks start just the robot: most need
# no more, and two fewer processes per runtime keep the suite's time (test_modbus_runtime
# starts the whole cell).
ROBOT_ONLY_ENV = {"OPENPENDANT_DEVICES": json.dumps([default_devices()[0].model_dump()])}
# Robots come up at the full speed override in tests and benchmarks (the site's default is
# 10 %: every move and jog would take ten times as long); test_first_speed.py
# and the browser's first hold run with the default.
FULL_SPEED_ENV = {"OPENPENDANT_LINK__FIRST_SPEED_RATIO": "1.0"}
# For tests that only need moves to finish: the simulated robots play trajectories 5x faster
# than real time (their states keep wall-clock stamps; jogs and streams stay in real time).
FAST_MOTION_ENV = {"OPENPENDANT_SIM_TIME_SCALE": "5"}


def child_env(home: Path, **extra: str) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("OPENPENDANT_SETTINGS_JSON", None)
    env.update(LOOPBACK_ENV)
    env.update(ROBOT_ONLY_ENV)
    env.update(FULL_SPEED_ENV)
    env["XDG_DATA_HOME"] = str(home)
    env["PYTHONUNBUFFERED"] = "1"
    env.update(extra)
    return env


def whole_cell_env(home: Path, **extra: str) -> dict[str, str]:
    """child_env, with the configured devices (by default or in a config file) rather than
    just the robot."""
    env = child_env(home, **extra)
    if "OPENPENDANT_DEVICES" not in extra:
        del env["OPENPENDANT_DEVICES"]
    return env


def free_port() -> int:
    with contextlib.closing(socket.socket(socket.AF_INET, socket.SOCK_STREAM)) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_for(
    check: Callable[[], T | None], timeout: float, interval: float = 0.05, what: str = "condition"
) -> T:
    deadline = time.monotonic() + timeout
    last_error: Exception | None = None
    while time.monotonic() < deadline:
        try:
            result = check()
            if result:
                return result
        except (httpx.HTTPError, OSError, ValueError, KeyError) as exc:
            last_error = exc
        time.sleep(interval)
    raise TimeoutError(
        f"timed out after {timeout} s waiting for {what}"
        + (f" (last error: {last_error})" if last_error else "")
    )


# The processes tests have started (those stopped in the last minutes too): a failed
# test's report shows their warnings (tests/conftest.py), CI's only account of a failure.
STARTED: list[Proc] = []
KEPT_AFTER_STOP = 600.0  # s


class Proc:
    """A child process whose stdout lines are collected by a reader thread."""

    def __init__(self, argv: list[str], env: dict[str, str], log_path: Path, nice: int = 0) -> None:
        self.argv = argv
        self.log_path = log_path
        log_path.parent.mkdir(parents=True, exist_ok=True)
        self._log = log_path.open("ab")
        self.lines: queue.Queue[str] = queue.Queue()
        spawned = ZYGOTE.spawn(argv, env, self._log, nice)
        self.popen: subprocess.Popen[bytes] | Spawned
        if spawned is not None:
            self.popen = spawned
        else:
            self.popen = subprocess.Popen(
                argv,
                env=env,
                stdout=subprocess.PIPE,
                stderr=self._log,
                stdin=subprocess.DEVNULL,
                preexec_fn=(lambda: os.nice(nice)) if nice else None,
            )
        self._terminated = False
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self.stopped_at: float | None = None
        STARTED[:] = [
            p
            for p in STARTED
            if p.stopped_at is None or p.stopped_at > time.time() - KEPT_AFTER_STOP
        ]
        STARTED.append(self)

    def log_files(self) -> list[Path]:
        """Where this process (and, for a runtime, each of its services) logs."""
        return [self.log_path]

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for raw in self.popen.stdout:
            self._log.write(raw)
            self._log.flush()
            self.lines.put(raw.decode(errors="replace").rstrip("\n"))

    def wait_line(self, match: Callable[[str], bool], timeout: float) -> str:
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or (self.popen.poll() is not None and self.lines.empty()):
                raise TimeoutError(
                    f"{self.argv[2:4]} did not print the expected line; see {self.log_path}"
                )
            try:
                line = self.lines.get(timeout=min(remaining, 0.2))
            except queue.Empty:
                continue
            if match(line):
                return line

    @property
    def pid(self) -> int:
        return self.popen.pid

    def alive(self) -> bool:
        return self.popen.poll() is None

    def stop(self, timeout: float = 10.0) -> int:
        if self.alive() and not self._terminated:
            self.terminate()
        if self.alive():
            try:
                self.popen.wait(timeout)
            except subprocess.TimeoutExpired:
                self.popen.kill()
        code = self.popen.wait()
        self._reader.join(timeout=2)
        self._log.close()
        self.stopped_at = time.time()
        return code

    def terminate(self) -> None:
        """SIGTERM, once (a second one may cut a process's orderly shutdown short)."""
        if self.alive():
            self.popen.send_signal(signal.SIGTERM)
            self._terminated = True

    def kill(self) -> None:
        self.popen.kill()
        self.popen.wait()


def log_entries(log: Path, levels: tuple[str, ...]) -> Iterator[dict[str, Any]]:
    """The JSON log entries of a process's log at one of `levels` (other lines skipped)."""
    with contextlib.suppress(OSError):
        for line in log.read_text(errors="replace").splitlines():
            with contextlib.suppress(ValueError):
                entry = json.loads(line)
                if isinstance(entry, dict) and entry.get("level") in levels:
                    yield entry


def warnings_since(since: float, limit: int = 60) -> list[str]:
    """Warning- and error-level log entries stamped at or after `since` (epoch seconds) of
    the processes running since then, oldest first, the last `limit` of them."""
    found: list[tuple[float, str]] = []
    for proc in [p for p in STARTED if p.stopped_at is None or p.stopped_at >= since]:
        for log in proc.log_files():
            for entry in log_entries(log, ("warning", "error", "critical")):
                ts = entry.get("ts")
                if isinstance(ts, int | float) and ts >= since:
                    text = f"{entry.get('service', log.stem)}: {entry.get('msg')}"
                    found.append((ts, f"{entry.get('time')} {text} {entry.get('exc', '')}"))
    found.sort()
    return [text.rstrip() for _, text in found[-limit:]]


def stop_all(procs: Iterable[Proc], timeout: float = 10.0) -> None:
    """Stop several at once: each is told first, then each waited for."""
    procs = list(procs)
    for proc in procs:
        proc.terminate()
    for proc in procs:
        proc.stop(timeout)


class Runtime(Proc):
    """`openpendant run` on a free port with its own data directory."""

    def __init__(
        self,
        home: Path,
        port: int | None = None,
        extra: list[str] | None = None,
        env: dict[str, str] | None = None,
    ) -> None:
        self.home = home
        self.port = port or free_port()
        self.data_dir = home / "openpendant"
        argv = [
            sys.executable,
            "-m",
            "openpendant.runtime.cli",
            "run",
            "--port",
            str(self.port),
            "--data-dir",
            str(self.data_dir),
            *(extra or []),
        ]
        super().__init__(argv, env or child_env(home), home / "logs" / f"runtime-{self.port}.log")
        self.url = ""
        # What its HTTPS is checked against (its own certificate authority), once it is up;
        # one context made once, never httpx's default (a new one per request: 30 ms of CPU
        # each, which polling loops spent at 50 ms intervals).
        self.verify: ssl.SSLContext = CLIENT_TLS
        self.started_in = 0.0
        self._tokens: dict[str, str] = {}
        self._users: set[str] = set()  # made in its store by user()

    def wait_ready(self, timeout: float = 60.0) -> str:
        t0 = time.monotonic()
        line = self.wait_line(lambda s: "OpenPendant UI:" in s, timeout)
        self.started_in = time.monotonic() - t0
        self.url = line.split("OpenPendant UI:", 1)[1].strip().rstrip("/")
        if self.url.startswith("https:"):
            ca = self.data_dir / TLS_DIR / CA_CERT
            self.verify = ssl.create_default_context(cafile=str(ca))
        return self.url

    def token(self, role: str = "admin") -> str:
        """An API token of `role`, made as `openpendant token create` makes one."""
        if role not in self._tokens:
            self._tokens[role] = create_token(self.data_dir, role, f"tests-{role}")
        return self._tokens[role]

    def auth(self, role: str = "admin") -> dict[str, str]:
        return {"Authorization": f"Bearer {self.token(role)}"}

    def user(self, role: str = "admin") -> tuple[str, str]:
        """A user of `role` (made in the runtime's user store, as an administrator would)."""
        name, password = f"{role}-user", f"{role}-password-0"
        if name in self._users:
            return name, password  # a store opened costs a password hash (its dummy)
        store = AuthStore(auth_path(self.data_dir))
        try:
            if name not in [u.name for u in store.users()]:
                store.create_user(name, password, Role.named(role))
        finally:
            store.close()
        self._users.add(name)
        return name, password

    def session_cookie(self, role: str = "admin") -> str:
        """A signed-in session of a `role` user: the cookie a browser would hold."""
        name, password = self.user(role)
        response = httpx.post(
            f"{self.url}/api/auth/login",
            json={"user": name, "password": password},
            timeout=10,
            verify=self.verify,
        )
        response.raise_for_status()
        return str(response.cookies["op_session"])

    def internal(self) -> dict[str, str]:
        """What a service's own port wants (the run's secret, kept in the data directory)."""
        token = (self.data_dir / INTERNAL_FILE).read_text().strip()
        return {INTERNAL_HEADER: token}

    def ws_url(self, path: str) -> str:
        """A socket of the gateway (path below /api)."""
        return self.url.replace("http", "ws", 1) + "/api" + path

    def log_files(self) -> list[Path]:
        return [self.log_path, *sorted((self.data_dir / "logs").glob("*.log"))]

    def service_errors(self) -> list[str]:
        """Error-level entries in the service logs: a clean run has none."""
        return [
            f"{log.name}: {entry.get('msg')} {entry.get('exc', '')}"
            for log in sorted((self.data_dir / "logs").glob("*.log"))
            for entry in log_entries(log, ("error", "critical"))
        ]

    def own_device(self, spec: DeviceSpec | None = None) -> dict[str, Any]:
        """One of the devices this runtime started (by default its simulated UR5), once
        detected (other runtimes on the same loopback announce theirs too)."""
        installation = (self.data_dir / "runtime-id").read_text().strip()
        spec = spec or default_devices()[0]
        name = spec.name
        uuid = device_uuid(installation, spec)
        return wait_for(
            lambda: next(
                (d for d in self.api("GET", "/devices/detected").json() if d["uuid"] == uuid),
                None,
            ),
            10,
            what=f"this runtime's {name} detected",
        )

    def is_detected(self, uuid: str) -> bool:
        return any(d["uuid"] == uuid for d in self.api("GET", "/devices/detected").json())

    def api(
        self, method: str, path: str, role: str | None = "admin", **kwargs: Any
    ) -> httpx.Response:
        """A request to the gateway, signed in with a token of `role` (None: anonymous)."""
        kwargs.setdefault("timeout", 10.0)
        kwargs.setdefault("verify", self.verify)
        if role is not None:
            kwargs["headers"] = {**self.auth(role), **(kwargs.get("headers") or {})}
        return httpx.request(method, f"{self.url}/api{path}", **kwargs)


class SimRobotProc(Proc):
    """`openpendant sim-robot` as a standalone, advertised device."""

    def __init__(
        self,
        home: Path,
        name: str,
        model: str = "ur5",
        port: int = 0,
        extra: list[str] | None = None,
        env: dict[str, str] | None = None,
        nice: int = 0,
    ) -> None:
        argv = [
            sys.executable,
            "-m",
            "openpendant.runtime.cli",
            "sim-robot",
            "--model",
            model,
            "--name",
            name,
            "--port",
            str(port),
            *(extra or []),
        ]
        super().__init__(
            argv,
            child_env(home, **(env or {})),
            home / "logs" / f"sim-{name}-{port}.log",
            nice=nice,
        )
        self.home = home
        self.url = ""
        self.uuid = ""

    def wait_ready(self, timeout: float = 30.0) -> str:
        line = self.wait_line(lambda s: s.startswith('{"event": "ready"'), timeout)
        ready = json.loads(line)
        self.url, self.uuid = ready["url"], ready["uuid"]
        return str(self.url)

    @property
    def secret(self) -> str:
        """Its pairing code (kept in its data directory, as a board keeps it)."""
        found = known_secret(self.home / "openpendant", self.uuid)
        assert found is not None, f"{self.uuid} keeps no secret"
        return found

    def client(self, timeout: float = 5.0) -> httpx.Client:
        """An HTTP client whose commands the device obeys (signed with its secret)."""
        auth = DeviceAuth(self.secret, follow_restarts=True)
        return httpx.Client(base_url=self.url, timeout=timeout, auth=auth, verify=CLIENT_TLS)

    def boot(self) -> str:
        """The boot id of the process serving now (in every answer's headers)."""
        return httpx.get(f"{self.url}/info", timeout=5, verify=CLIENT_TLS).headers[BOOT_HEADER]

    def signed(self, path: str) -> dict[str, str]:
        """The header that opens one of its command sockets."""
        return {DEVICE_AUTH: sign(self.secret, "GET", path, boot=self.boot())}


class DriverProc(SimRobotProc):
    """`openpendant driver NAME …`: any installed driver, as its own advertised device."""

    def __init__(self, home: Path, driver: str, name: str, *options: str) -> None:
        argv = [
            sys.executable,
            "-m",
            "openpendant.runtime.cli",
            "driver",
            driver,
            "--name",
            name,
            *options,
        ]
        Proc.__init__(self, argv, child_env(home), home / "logs" / f"{driver}-{name}.log")
        self.home = home
        self.url = ""
        self.uuid = ""


class SpaceMouseProc(SimRobotProc):
    """`openpendant spacemouse` playing a recording, on request."""

    def __init__(self, home: Path, name: str, recording: Path) -> None:
        argv = [
            sys.executable,
            "-m",
            "openpendant.runtime.cli",
            "spacemouse",
            "--source",
            "replay",
            "--replay",
            str(recording),
            "--replay-wait",
            "--name",
            name,
        ]
        Proc.__init__(self, argv, child_env(home), home / "logs" / f"mouse-{name}.log")
        self.home = home
        self.url = ""
        self.uuid = ""


@contextlib.contextmanager
def running(proc: Proc) -> Iterator[Proc]:
    try:
        yield proc
    finally:
        proc.stop()
