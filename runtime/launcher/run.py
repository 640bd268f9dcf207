"""Start the services and default simulated devices, wait until healthy, print the URL,
supervise until Ctrl-C or SIGTERM."""

from __future__ import annotations

import json
import logging
import signal
import socket
import sys
import time
import uuid
from types import FrameType

import httpx

from runtime import __version__
from runtime.kit.serve import listening_socket
from runtime.kit.settings import RuntimeSettings, settings_for_child
from runtime.launcher.supervisor import Child, Supervisor, process_env
from runtime.services import SERVICES, URLS_ENV, WEBUI

log = logging.getLogger("openpendant.launcher")

STARTUP_TIMEOUT = 60.0
SIM_NAMESPACE = uuid.UUID("3d0f54a8-5b0e-4a8e-9c5e-0f8d4b6a2c11")


class StartupFailed(RuntimeError):
    pass


def _service_child(
    name: str,
    sock: socket.socket,
    env: dict[str, str],
    settings: RuntimeSettings,
    public: socket.socket | None = None,
) -> Child:
    fd = sock.fileno()
    argv = [sys.executable, "-m", "runtime.cli", "service", name, "--fd", str(fd)]
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
    )


def runtime_id(settings: RuntimeSettings) -> str:
    """This installation's own id (made once, kept in the data directory)."""
    path = settings.data_dir / "runtime-id"
    try:
        return path.read_text().strip()
    except FileNotFoundError:
        made = uuid.uuid4().hex
        path.write_text(made + "\n")
        return made


def _sim_children(settings: RuntimeSettings, env: dict[str, str]) -> list[Child]:
    if not settings.sim:
        return []
    # Two runtimes on one network each simulate their own "sim-ur5": the uuid is this
    # installation's, not just the model's and name's, so neither adds the other's robot.
    installation = runtime_id(settings)
    return [
        Child(
            name=f"sim-robot:{spec.name}",
            argv=[
                sys.executable,
                "-m",
                "device_drivers.sim_robot",
                "--model",
                spec.model,
                "--name",
                spec.name,
                "--uuid",
                str(uuid.uuid5(SIM_NAMESPACE, f"{installation}/{spec.model}/{spec.name}")),
                "--host",
                settings.host if settings.host != "localhost" else "127.0.0.1",
                "--port",
                "0",
            ],
            env=env,
            log_path=settings.logs / f"sim-robot-{spec.name}.log",
        )
        for spec in settings.sim_robots
    ]


def wait_healthy(urls: dict[str, str], supervisor: Supervisor, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    pending = dict(urls)
    with httpx.Client(timeout=1.0) as client:
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


def run(settings: RuntimeSettings) -> int:
    started = time.monotonic()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    settings.logs.mkdir(parents=True, exist_ok=True)
    try:
        public = listening_socket(settings.host, settings.port)
    except OSError as exc:
        print(
            f"openpendant: cannot listen on {settings.host}:{settings.port}: {exc.strerror}. "
            "Choose another port with --port.",
            file=sys.stderr,
        )
        return 1
    sockets = {spec.name: listening_socket("127.0.0.1", 0) for spec in SERVICES}
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
    # Kept by the launcher like the others: the port survives a restart of the jog service.
    settings = settings.model_copy(update={"jog_port": int(jog_public.getsockname()[1])})
    env = process_env({**settings_for_child(settings), URLS_ENV: json.dumps(urls)})

    supervisor = Supervisor()

    def on_signal(signum: int, _: FrameType | None) -> None:
        supervisor.stopping = True

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)

    for spec in SERVICES:
        public_socket = jog_public if spec.public_paths else None
        supervisor.add(_service_child(spec.name, sockets[spec.name], env, settings, public_socket))
    supervisor.add(_service_child(WEBUI.name, public, env, settings))
    for child in _sim_children(settings, env):
        supervisor.add(child)

    ui_host = "127.0.0.1" if settings.host in ("0.0.0.0", "") else settings.host
    ui_url = f"http://{ui_host}:{public_port}/"
    try:
        wait_healthy({**urls, WEBUI.name: ui_url.rstrip("/")}, supervisor, STARTUP_TIMEOUT)
    except StartupFailed as exc:
        print(f"openpendant: start-up failed: {exc}. Logs: {settings.logs}", file=sys.stderr)
        supervisor.stop_all()
        return 1

    sims = (
        ", ".join(f"{s.name} ({s.model})" for s in settings.sim_robots) if settings.sim else "none"
    )
    print(
        f"OpenPendant {__version__} is running (started in "
        f"{time.monotonic() - started:.1f} s).\n"
        f"  OpenPendant UI: {ui_url}\n"
        f"  Logs: {settings.logs}\n"
        f"  Data: {settings.data_dir}\n"
        f"  Simulated robots: {sims}\n"
        "The on-screen STOP is a software stop, not an emergency stop.\n"
        "Press Ctrl-C to stop.",
        flush=True,
    )

    while not supervisor.stopping:
        supervisor.poll()
        time.sleep(0.1)
    print("Stopping OpenPendant…", flush=True)
    supervisor.stop_all()
    print("Stopped.", flush=True)
    return 0
