"""The runtime as a user installs it: `pip install .` (a wheel, not editable) into a new,
empty virtual environment, its dependencies from the package index (pip's cache), nothing
borrowed from the project's own environment, run from outside the source tree. It installs
one package, `openpendant` (and the example plugin one more of its own), comes up healthy,
serves the UI, finds its robot models, detects its simulated robot, and its benchmarks run."""

from __future__ import annotations

import json
import subprocess
import sys
import venv
from pathlib import Path

import httpx
import pytest

from openpendant.runtime.bench.harness.processes import Proc, child_env, free_port, wait_for
from openpendant.runtime.kit.settings import default_devices
from openpendant.runtime.launcher.run import device_uuid

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
    (wheel,) = wheels.glob("openpendant-*.whl")
    subprocess.run(
        [str(target / "bin" / "python"), "-m", "pip", "install", "--quiet", str(wheel)],
        check=True,
        capture_output=True,
        timeout=900,
    )
    return target


# What the repository keeps as top-level folders; installed, each is under openpendant.
BARE = ("runtime", "device_drivers", "sandbox", "blockly_blocks", "plugins", "webui", "deploy")


def site_packages(python: Path) -> Path:
    return Path(
        subprocess.run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout.strip()
    )


def installed_tops(site: Path, distribution: str) -> set[str]:
    """What a distribution put at the top of site-packages (from its RECORD)."""
    (record,) = site.glob(f"{distribution}-*.dist-info/RECORD")
    paths = [line.split(",")[0] for line in record.read_text().splitlines() if line]
    return {p.split("/")[0] for p in paths if not p.startswith("..")}


def test_site_packages_get_one_package_and_the_plugin_one_more(installed: Path) -> None:
    python = installed / "bin" / "python"
    site = site_packages(python)
    assert installed_tops(site, "openpendant") == {"openpendant", "openpendant-0.1.0.dist-info"}
    assert [name for name in BARE if (site / name).exists()] == []
    plugin = ROOT / "plugins" / "conveyor"
    subprocess.run(
        [str(python), "-m", "pip", "install", "--quiet", "--no-deps", str(plugin)],
        check=True,
        capture_output=True,
        timeout=300,
    )
    try:
        assert installed_tops(site, "openpendant_conveyor") == {
            "openpendant_conveyor",
            "openpendant_conveyor-0.1.0.dist-info",
        }
    finally:
        subprocess.run(
            [str(python), "-m", "pip", "uninstall", "--quiet", "--yes", "openpendant-conveyor"],
            check=True,
            capture_output=True,
            timeout=300,
        )


def test_the_installed_runtime_is_its_own(installed: Path) -> None:
    found = subprocess.run(
        [
            str(installed / "bin" / "python"),
            "-c",
            "import openpendant.runtime as runtime, openpendant.webui.server as server; "
            "import openpendant.deploy as deploy; print(runtime.__file__); "
            "print(server.DIST); print(deploy.__file__)",
        ],
        cwd=installed,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    for path in found:
        assert Path(path).is_relative_to(installed), f"{path} is not the installed copy"
    assert (Path(found[1]) / "index.html").is_file()


def test_the_installed_command_writes_its_own_systemd_units(
    installed: Path, tmp_path: Path
) -> None:
    """The units ship in the wheel, and name the installed command."""
    command = installed / "bin" / "openpendant"
    done = subprocess.run(
        [str(command), "install-service", "--root", str(tmp_path), "--no-enable"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    unit = (tmp_path / "etc" / "systemd" / "system" / "openpendant.service").read_text()
    assert f"ExecStart={command} run " in unit


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
        # The block categories' folders came with the package (their JSON is package data).
        blocks = httpx.get(f"{base}/api/programs/_blocks", headers=auth).json()
        categories = {"robot", "poses", "time", "io", "gripper", "vision", "store", "program"}
        assert categories <= set(blocks["definitions"])
        german = blocks["words"]["de"]["blocks"]["time_since_start"]
        assert german["message0"] == "Sekunden seit Start"
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
