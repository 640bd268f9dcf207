"""The runtime as a user installs it: `pip install .` (a wheel, not editable) into a new
virtual environment, run from outside the source tree. It comes up healthy, serves the UI,
finds its robot models, detects its simulated robot, and its benchmarks run.

The new environment borrows the third-party packages of the project's own (a `.pth` line
to its site-packages, listed after the new environment's own) instead of downloading them
again; the runtime itself — code, UI build, robot models, entry points — comes only from
the wheel built here."""

from __future__ import annotations

import json
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import httpx
import pytest

from runtime.bench.harness.processes import Proc, child_env, free_port, wait_for
from runtime.kit.settings import default_devices
from runtime.launcher.run import device_uuid

# No real-time margins here: runs alongside the rest (tests/suite.py).
pytestmark = pytest.mark.concurrent

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    home = tmp_path_factory.mktemp("install")
    wheels = home / "wheels"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--wheel-dir",
            str(wheels),
            str(ROOT),
        ],
        check=True,
        capture_output=True,
        timeout=300,
    )
    target = home / "venv"
    venv.create(target, with_pip=True)
    python = target / "bin" / "python"
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    borrowed = Path(sysconfig.get_paths()["purelib"])
    # Listed first (.pth files run in name order), then the others' path hooks (cmeel's,
    # which puts pinocchio on the path); the editable install's own is left out.
    (Path(site) / "0-borrowed-dependencies.pth").write_text(f"{borrowed}\n")
    for hook in borrowed.glob("*.pth"):
        if not hook.name.startswith("__editable__"):
            (Path(site) / hook.name).write_text(hook.read_text())
    (wheel,) = wheels.glob("openpendant-*.whl")
    subprocess.run(
        [str(python), "-m", "pip", "install", "--quiet", "--no-deps", str(wheel)],
        check=True,
        capture_output=True,
        timeout=300,
    )
    return target


def test_the_installed_runtime_is_its_own(installed: Path) -> None:
    found = subprocess.run(
        [
            str(installed / "bin" / "python"),
            "-c",
            "import runtime, webui.server, deploy; print(runtime.__file__); "
            "print(webui.server.DIST); print(deploy.__file__)",
        ],
        cwd=installed,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    for path in found:
        assert Path(path).is_relative_to(installed), f"{path} is not the installed copy"
    assert (Path(found[1]) / "index.html").is_file()


def test_the_installed_runtime_runs_serves_its_ui_and_detects_its_robot(
    installed: Path, tmp_path: Path
) -> None:
    port = free_port()
    runtime = Proc(
        [
            str(installed / "bin" / "openpendant"),
            "run",
            "--port",
            str(port),
            "--data-dir",
            str(tmp_path / "data"),
        ],
        child_env(tmp_path),
        tmp_path / "runtime.log",
    )
    try:
        runtime.wait_line(lambda line: "OpenPendant UI:" in line, 60)
        base = f"http://127.0.0.1:{port}"
        assert httpx.get(f"{base}/api/health").status_code == 401  # signed in, or nothing
        # A script's token, made on the runtime computer as the README says.
        token = subprocess.run(
            [
                str(installed / "bin" / "openpendant"),
                *("token", "create", "--role", "viewer", "--name", "install-check"),
                *("--data-dir", str(tmp_path / "data")),
            ],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        auth = {"Authorization": f"Bearer {token}"}
        assert httpx.get(f"{base}/api/health", headers=auth).json()["status"] == "ok"
        page = httpx.get(f"{base}/")
        assert page.status_code == 200 and "<op-app" in page.text
        installation = (tmp_path / "data" / "runtime-id").read_text().strip()
        own = device_uuid(installation, default_devices()[0])
        wait_for(
            lambda: any(
                d["uuid"] == own
                for d in httpx.get(f"{base}/api/devices/detected", headers=auth).json()
            ),
            10,
            what="the installed runtime's own simulated robot detected",
        )
    finally:
        assert runtime.stop() == 0


def test_the_installed_benchmarks_run(installed: Path, tmp_path: Path) -> None:
    out = tmp_path / "bench.json"
    result = subprocess.run(
        [
            str(installed / "bin" / "openpendant"),
            "bench",
            "--only",
            "discovery_time",
            "--json",
            str(out),
        ],
        cwd=tmp_path,
        env=child_env(tmp_path, OPENPENDANT_BENCH_QUICK="1"),
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert result.returncode == 0, result.stderr
    assert "discovery_time" in result.stdout
    figures = json.loads(out.read_text())
    figure = figures["discovery_time"]
    assert figure["unit"] == "s" and 0 < figure["value"] < 10
    assert figure["details"]["trials"] == 3
    assert "discovery_from_process_start" not in figures  # --only names one figure
