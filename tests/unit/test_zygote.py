"""The tests' zygote forks `openpendant` commands that behave as fresh interpreters would:
their own arguments, environment and streams, exit codes and signals as
a Popen reports them, and a fresh start where a fork could not be the same."""

import os
import signal
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from openpendant.runtime.bench.harness import zygote
from openpendant.runtime.bench.harness.zygote import Spawned, ZygoteClient
from tests.support import netns

pytestmark = pytest.mark.concurrent

CLI = [sys.executable, "-m", "openpendant.runtime.cli"]


@pytest.fixture
def client(monkeypatch: pytest.MonkeyPatch) -> Iterator[ZygoteClient]:
    monkeypatch.setenv(zygote.ENV, "1")
    made = ZygoteClient()
    yield made
    made._stop()


def spawned(client: ZygoteClient, tmp_path: Path, *args: str, **env: str) -> Spawned | None:
    with (tmp_path / "stderr.log").open("ab") as log:
        return client.spawn([*CLI, *args], {**os.environ, **env}, log)


def spawn(client: ZygoteClient, tmp_path: Path, *args: str, **env: str) -> Spawned:
    made = spawned(client, tmp_path, *args, **env)
    assert made is not None
    return made


def test_a_command_runs_with_its_arguments_and_reports_its_exit(
    client: ZygoteClient, tmp_path: Path
) -> None:
    listed = spawn(client, tmp_path, "driver", "--list")
    assert "sim-robot" in listed.stdout.read().decode()
    assert listed.wait(30) == 0
    unknown = spawn(client, tmp_path, "service", "no-such-service")
    assert unknown.wait(30) != 0
    assert "no service 'no-such-service'" in (tmp_path / "stderr.log").read_text()


def test_a_child_has_its_own_environment_and_takes_signals(
    client: ZygoteClient, tmp_path: Path
) -> None:
    """A driver given a data home of its own keeps its secret there."""
    robot = spawn(
        client,
        tmp_path,
        "sim-robot",
        "--name",
        "zygote-test",
        "--port",
        "0",
        XDG_DATA_HOME=str(tmp_path / "data"),
    )
    assert robot.stdout.readline().startswith(b'{"event": "ready"')
    assert list((tmp_path / "data").rglob("*")), "nothing kept in the child's own data home"
    assert robot.poll() is None
    robot.send_signal(signal.SIGKILL)
    assert robot.wait(10) == -signal.SIGKILL


def test_what_a_fork_cannot_be_is_left_to_a_fresh_interpreter(
    client: ZygoteClient, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = (tmp_path / "stderr.log").open("ab")
    other_path = {**os.environ, "PYTHONPATH": str(tmp_path)}
    assert client.spawn([*CLI, "--version"], other_path, log) is None
    assert client.spawn([sys.executable, "-c", "pass"], dict(os.environ), log) is None
    opted_out = {**os.environ, zygote.ENV: "0"}  # one process a test wants started afresh
    assert client.spawn([*CLI, "--version"], opted_out, log) is None
    monkeypatch.setenv(zygote.ENV, "0")
    assert client.spawn([*CLI, "--version"], dict(os.environ), log) is None
    log.close()


@pytest.mark.skipif(netns.available() is not None, reason=str(netns.available()))
def test_a_thread_in_a_network_of_its_own_gets_a_fresh_interpreter(
    client: ZygoteClient, tmp_path: Path
) -> None:
    """A fork of the zygote would be in the zygote's network, not the thread's."""
    network = netns.Network()
    try:
        namespace = network.namespace("zyg")
        with netns.inside(namespace):
            assert spawned(client, tmp_path, "--version") is None
        outside = spawned(client, tmp_path, "--version")
        assert outside is not None and outside.wait(30) == 0
    finally:
        network.close()


def test_a_package_installed_since_it_started_starts_it_afresh(
    client: ZygoteClient, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    site = tmp_path / "site"
    site.mkdir()
    monkeypatch.syspath_prepend(str(site))
    assert spawn(client, tmp_path, "--version").wait(30) == 0
    first = client._proc
    assert spawn(client, tmp_path, "--version").wait(30) == 0
    assert client._proc is first
    robot = spawn(
        client,
        tmp_path,
        *("sim-robot", "--name", "zygote-kept", "--port", "0"),
        XDG_DATA_HOME=str(tmp_path / "data"),
    )
    assert robot.stdout.readline().startswith(b'{"event": "ready"')
    (site / "new_package").mkdir()
    assert spawn(client, tmp_path, "--version").wait(30) == 0
    assert client._proc is not first
    assert robot.poll() is None, "a child of the old zygote ended with the new one's start"
    robot.terminate()
    robot.wait(10)
