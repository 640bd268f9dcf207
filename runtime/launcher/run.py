"""Start the services and default simulated devices, wait until healthy, print the URL,
supervise until Ctrl-C or SIGTERM."""

from __future__ import annotations

import contextlib
import gc
import json
import logging
import os
import secrets
import signal
import socket
import ssl
import sys
import time
import uuid
from pathlib import Path
from types import FrameType

import httpx

from openpendant.plugins.api import resolve
from openpendant.plugins.registry import registry
from openpendant.runtime import __version__
from openpendant.runtime.auth.setup import SETUP_CODE_ENV, auth_path, auth_store, needs_setup
from openpendant.runtime.kit.internal import ENV as INTERNAL_ENV
from openpendant.runtime.kit.internal import FILE as INTERNAL_FILE
from openpendant.runtime.kit.private_files import keep_private, shown_secret
from openpendant.runtime.kit.serve import listening_socket
from openpendant.runtime.kit.settings import DeviceSpec, RuntimeSettings, settings_for_child
from openpendant.runtime.kit.tls import (
    CA_DOWNLOAD,
    TLS_DIR,
    TlsError,
    TlsFiles,
    probe_context,
)
from openpendant.runtime.kit.tls import prepare as prepare_tls
from openpendant.runtime.launcher.backup import BackupError, check_databases, data_lock
from openpendant.runtime.launcher.notify import Notifier, Watchdog
from openpendant.runtime.launcher.supervisor import Child, Main, Supervisor, process_env
from openpendant.runtime.services import URLS_ENV, WEBUI, all_services, services

log = logging.getLogger("openpendant.launcher")

STARTUP_TIMEOUT = 60.0
SIM_NAMESPACE = uuid.UUID("3d0f54a8-5b0e-4a8e-9c5e-0f8d4b6a2c11")


class StartupFailed(RuntimeError):
    pass


SPAWN_ENV = "OPENPENDANT_SPAWN"


def forking(entry: Main) -> Main | None:
    """How children start: forked from this process (its imports shared copy-on-write),
    each running `entry` (the `openpendant` command's), or with OPENPENDANT_SPAWN=exec each
    as a fresh interpreter."""
    if os.environ.get(SPAWN_ENV, "fork") == "exec":
        return None
    return entry


def preload(settings: RuntimeSettings) -> None:
    """Import, once, what the children will run, then keep those objects out of every later
    garbage collection (which would write to, and so un-share, their pages). What fails to
    import here is left to the child, which reports it in its own log."""
    modules = [spec.factory for spec in (*services(), WEBUI)]
    drivers = registry().drivers
    for device in settings.devices:
        driver = drivers.get(device.driver)
        if driver is not None:
            modules += [r for r in (driver.factory, driver.options, driver.routes) if r]
    modules += [
        "openpendant.runtime.drivers.run:run_driver",
        "openpendant.runtime.services:run_service",
    ]
    for reference in modules:
        try:
            resolve(reference)
        except Exception as exc:  # the child will say so in its log
            log.debug("not preloaded: %s (%s)", reference, exc)
    gc.collect()
    gc.freeze()


def _service_child(
    name: str,
    sock: socket.socket,
    env: dict[str, str],
    settings: RuntimeSettings,
    public: socket.socket | None = None,
    main: Main | None = None,
) -> Child:
    fd = sock.fileno()
    argv = [sys.executable, "-m", "openpendant.runtime.cli", "service", name, "--fd", str(fd)]
    fds = [fd]
    if public is not None:
        argv += ["--public-fd", str(public.fileno())]
        fds.append(public.fileno())
    return Child(
        name=name,
        argv=argv,
        env=env,
        log_path=settings.logs / f"{name}.log",
        pass_fds=tuple(fds),
        main=main,
    )


SETUP_FILE = "setup-code"


def run_secrets(data_dir: Path) -> tuple[str, str]:
    """This run's secret between its processes (kept where the owner's tools can read it),
    and the one-time code that lets another computer set up the first administrator."""
    internal = secrets.token_urlsafe(32)
    path = data_dir / INTERNAL_FILE
    path.touch(mode=0o600)
    path.chmod(0o600)
    path.write_text(internal + "\n")
    return internal, f"{secrets.randbelow(10**4):04d}-{secrets.randbelow(10**4):04d}"


def runtime_id(settings: RuntimeSettings) -> str:
    """This installation's own id (made once, kept in the data directory)."""
    path = settings.data_dir / "runtime-id"
    try:
        return path.read_text().strip()
    except FileNotFoundError:
        made = uuid.uuid4().hex
        path.write_text(made + "\n")
        return made


def device_uuid(installation: str, spec: DeviceSpec) -> str:
    """A device the launcher starts is this installation's: two runtimes on one network each
    simulating their "sim-ur5" do not share a uuid, so neither adds the other's robot. A
    device with a `model` option is named by it, as the simulated robots of the earlier
    `sim_robots:` list were, so robots added then are still recognised."""
    model = spec.options.get("model")
    middle = model if isinstance(model, str) and model else spec.driver
    return str(uuid.uuid5(SIM_NAMESPACE, f"{installation}/{middle}/{spec.name}"))


def _device_children(
    settings: RuntimeSettings, env: dict[str, str], main: Main | None = None
) -> list[Child]:
    """The `devices` list: each an installed driver in a process of its own (simulated ones
    only with `sim`)."""
    drivers = registry().drivers
    children = []
    installation = runtime_id(settings)
    for spec in settings.devices:
        driver = drivers.get(spec.driver)
        if driver is None:
            log.error("devices: no driver %r is installed; %s not started", spec.driver, spec.name)
            continue
        if (driver.simulated or spec.options.get("simulate") is True) and not settings.sim:
            continue
        children.append(
            Child(
                name=f"{spec.driver}:{spec.name}",
                argv=[
                    sys.executable,
                    "-m",
                    "openpendant.runtime.cli",
                    "driver",
                    spec.driver,
                    "--name",
                    spec.name,
                    "--uuid",
                    device_uuid(installation, spec),
                    "--host",
                    settings.host if settings.host != "localhost" else "127.0.0.1",
                    "--port",
                    "0",
                    "--options-json",
                    json.dumps(spec.options),
                ],
                env=env,
                log_path=settings.logs / f"{spec.driver}-{spec.name}.log",
                main=main,
            )
        )
    return children


SECURE_SESSIONS = "sessions-over-https"  # in the tls folder: every session began over HTTPS


def sessions_follow_transport(settings: RuntimeSettings, tls: TlsFiles | None) -> None:
    """Sessions signed in over plain HTTP end when HTTPS is turned on: their cookies are not
    `Secure`, and a browser would still send them in clear to the plain port."""
    data_dir = settings.data_dir
    marker = data_dir / TLS_DIR / SECURE_SESSIONS
    if tls is None:
        marker.unlink(missing_ok=True)
        return
    if marker.exists():
        return
    if auth_path(data_dir).exists():
        store = auth_store(settings)  # the site's session limits: how long a why is kept
        try:
            ended = store.end_every_session("secure_connection")
        finally:
            store.close()
        if ended:
            log.info("HTTPS is on: %d session(s) signed in over plain HTTP ended", ended)
    marker.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    marker.touch(mode=0o600)


def tls_lines(tls: TlsFiles, redirect: socket.socket | None) -> str:
    """What the start-up message says of HTTPS: what a tablet checks before trusting it."""
    what = "certificate authority" if tls.ca is not None else "certificate"
    lines = f"  HTTPS: the {what}'s SHA-256 fingerprint is {tls.fingerprint()}\n"
    if tls.ca is not None:
        lines += f"    (a tablet installs it from {CA_DOWNLOAD} and checks that fingerprint)\n"
    if redirect is not None:
        lines += f"  Plain HTTP on port {redirect.getsockname()[1]} is sent on to HTTPS.\n"
    return lines


def wait_healthy(
    urls: dict[str, str],
    supervisor: Supervisor,
    timeout: float,
    verify: ssl.SSLContext | bool = True,
) -> None:
    deadline = time.monotonic() + timeout
    pending = dict(urls)
    with httpx.Client(timeout=1.0, verify=verify) as client:
        while pending:
            if supervisor.stopping:
                raise StartupFailed("stopped during start-up")
            for name, url in list(pending.items()):
                try:
                    if client.get(f"{url}/health").status_code == 200:
                        del pending[name]
                except httpx.HTTPError:
                    pass
            if not pending:
                return
            if time.monotonic() > deadline:
                raise StartupFailed(f"not healthy after {timeout:.0f} s: {', '.join(pending)}")
            supervisor.poll()
            time.sleep(0.05)


def run(settings: RuntimeSettings, entry: Main) -> int:
    """`entry`: what a forked child runs with its command line (the `openpendant` command's
    main: passed down, so that the launcher does not import the command above it)."""
    started = time.monotonic()
    notifier = Notifier()  # before any child could inherit systemd's variables
    # Small matrices only: one thread each (no BLAS or OpenMP pools per process, and none
    # alive in this process when it forks).
    for threads in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
        os.environ.setdefault(threads, "1")
    keep_private(settings.data_dir, settings.logs)
    using = contextlib.ExitStack()  # held until this process ends: one runtime per data dir
    try:
        using.enter_context(data_lock(settings.data_dir))
        check_databases(settings.data_dir)
    except BackupError as exc:
        print(f"openpendant: {exc}", file=sys.stderr)
        return 1
    try:
        tls = prepare_tls(settings)
    except TlsError as exc:
        print(f"openpendant: {exc}", file=sys.stderr)
        return 1
    sessions_follow_transport(settings, tls)
    try:
        public = listening_socket(settings.host, settings.port)
    except OSError as exc:
        print(
            f"openpendant: cannot listen on {settings.host}:{settings.port}: {exc.strerror}. "
            "Choose another port with --port.",
            file=sys.stderr,
        )
        return 1
    declared = services()
    sockets = {spec.name: listening_socket("127.0.0.1", 0) for spec in declared}
    urls = {name: f"http://127.0.0.1:{s.getsockname()[1]}" for name, s in sockets.items()}
    public_port = public.getsockname()[1]
    try:
        jog_public = listening_socket(settings.host, settings.jog_port)
    except OSError as exc:
        print(
            f"openpendant: cannot listen on {settings.host}:{settings.jog_port} for the jog "
            f"socket: {exc.strerror}. Choose another port with jog_port.",
            file=sys.stderr,
        )
        return 1
    redirect = None
    if tls is not None and settings.tls.redirect_port is not None:
        try:
            redirect = listening_socket(settings.host, settings.tls.redirect_port)
        except OSError as exc:
            print(
                f"openpendant: cannot listen on {settings.host}:{settings.tls.redirect_port} "
                f"for plain HTTP: {exc.strerror}. Choose another tls.redirect_port.",
                file=sys.stderr,
            )
            return 1
    # Kept by the launcher like the others: the port survives a restart of the jog service.
    # The UI's port is the origin its pages come from (the services check it; see web_guard).
    settings = settings.model_copy(
        update={"jog_port": int(jog_public.getsockname()[1]), "port": int(public_port)}
    )
    internal, setup_code = run_secrets(settings.data_dir)
    env = process_env(
        {
            **settings_for_child(settings),
            URLS_ENV: json.dumps(urls),
            INTERNAL_ENV: internal,
            SETUP_CODE_ENV: setup_code,
        }
    )

    main = forking(entry)
    if main is not None:
        preload(settings)
    supervisor = Supervisor(settings.restart_healthy_after, settings.restart_backoff)

    def on_signal(signum: int, _: FrameType | None) -> None:
        supervisor.stopping = True

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)

    for spec in declared:
        public_socket = jog_public if spec.public_paths else None
        supervisor.add(
            _service_child(spec.name, sockets[spec.name], env, settings, public_socket, main)
        )
    webui = _service_child(WEBUI.name, public, env, settings, main=main)
    if redirect is not None:
        webui.argv += ["--redirect-fd", str(redirect.fileno())]
        webui.pass_fds += (redirect.fileno(),)
    supervisor.add(webui)
    for child in _device_children(settings, env, main):
        supervisor.add(child)

    ui_host = "127.0.0.1" if settings.host in ("0.0.0.0", "") else settings.host
    scheme = "https" if tls is not None else "http"
    ui_url = f"{scheme}://{ui_host}:{public_port}/"
    verify = probe_context() if tls is not None else True
    try:
        wait_healthy({**urls, WEBUI.name: ui_url.rstrip("/")}, supervisor, STARTUP_TIMEOUT, verify)
    except StartupFailed as exc:
        print(f"openpendant: start-up failed: {exc}. Logs: {settings.logs}", file=sys.stderr)
        supervisor.stop_all()
        return 1

    notifier.send("READY=1", f"STATUS=OpenPendant UI at {ui_url}", f"MAINPID={os.getpid()}")
    watchdog = Watchdog(notifier, {**urls, WEBUI.name: ui_url.rstrip("/")}, verify=verify)
    watchdog.start()
    names = [c.name for c in supervisor.children if c.name not in all_services()]
    devices = ", ".join(names) or "none"
    setup_file = settings.data_dir / SETUP_FILE
    print(
        f"OpenPendant {__version__} is running (started in "
        f"{time.monotonic() - started:.1f} s).\n"
        f"  OpenPendant UI: {ui_url}\n"
        + (tls_lines(tls, redirect) if tls is not None else "")
        + f"  Logs: {settings.logs}\n"
        f"  Data: {settings.data_dir}\n"
        f"  Devices: {devices}\n"
        + (
            f"  First start: open the UI to create the administrator (from another computer "
            f"give the set-up code {shown_secret(setup_code, setup_file, sys.stdout)}).\n"
            if needs_setup(settings.data_dir)
            else ""
        )
        + "The on-screen STOP is a software stop, not an emergency stop.\n"
        "Press Ctrl-C to stop.",
        flush=True,
    )

    while not supervisor.stopping:
        supervisor.poll()
        time.sleep(0.1)
    print("Stopping OpenPendant…", flush=True)
    notifier.send("STOPPING=1")
    watchdog.stop()
    supervisor.stop_all()
    print("Stopped.", flush=True)
    return 0
