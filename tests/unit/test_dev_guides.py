"""The developer's guides (docs/dev/) build what they say: each guide's files are taken from
the guide as written (a fenced block whose first line is `# path`), and what it promises is
checked against them. A guide that drifts from the code fails here."""

from __future__ import annotations

import asyncio
import importlib.metadata
import json
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from openpendant.blockly_blocks.catalog import toolbox, words
from openpendant.blockly_blocks.generate import generate
from openpendant.plugins.api import resolve
from openpendant.plugins.registry import load
from openpendant.runtime.drivers.host import build_driver_app
from openpendant.runtime.drivers.run import options_model
from openpendant.sandbox.supervisor import ProgramRun, RunLimits, RunState, WorkerPool
from tests.unit.test_sandbox_attacks import RecordingHost

ROOT = Path(__file__).resolve().parents[2]
SPARE_WAITS = 3.0  # s
BLOCK = re.compile(r"^```(\w+)\n(?:#|//) (\S+)\n(.*?)^```$", re.M | re.S)


def guide_files(guide: Path) -> dict[str, str]:
    """The files a guide writes: path -> text (the `# path` line dropped from code, kept
    out of TOML too)."""
    return {path: body for _, path, body in BLOCK.findall(guide.read_text())}


def build(guide: Path, into: Path) -> list[str]:
    files = guide_files(guide)
    for path, text in files.items():
        target = into / path
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(text)
    return sorted(files)


@pytest.fixture
def loopback(tmp_path: Path) -> Iterator[Path]:
    """The driver guide's package, importable (and, with a dist-info of its own, found by
    entry points as an installed plugin would be)."""
    written = build(ROOT / "docs" / "dev" / "driver.md", tmp_path)
    assert written == [
        "loopback_io/__init__.py",
        "loopback_io/driver.py",
        "loopback_io/entry.py",
        "pyproject.toml",
    ]
    sys.path.insert(0, str(tmp_path))
    try:
        yield tmp_path
    finally:
        sys.path.remove(str(tmp_path))
        for name in [m for m in sys.modules if m == "loopback_io" or m.startswith("loopback_io.")]:
            del sys.modules[name]


def test_the_driver_guide_builds_a_driver_that_serves_its_interface(loopback: Path) -> None:
    entry_points = (loopback / "pyproject.toml").read_text()
    assert 'loopback-io = "loopback_io:PLUGIN"' in entry_points
    entry = importlib.metadata.EntryPoint(
        name="loopback-io", value="loopback_io:PLUGIN", group="openpendant.plugins"
    )
    plugins = load([entry])
    assert plugins.failures == []
    spec = plugins.drivers["loopback-io"]
    options = options_model(spec)(channels=2)
    driver = resolve(spec.factory)("bench_io", "7e3a0c4e-0000-4000-8000-00000000b10c", options)
    app = build_driver_app(driver, advertisement=None, interfaces=[], state_rate_hz=50)
    with TestClient(app) as device:
        info = device.get("/info").json()
        assert info["identity"]["kind"] == "io"
        assert [s["name"] for s in info["info"]["signals"]] == ["out_1", "in_1", "out_2", "in_2"]
        written = device.put("/signals/out_2", json={"value": True})
        assert written.status_code == 200 and written.json()["value"] is True
        assert device.get("/signals/in_2").json()["value"] is True
        assert device.get("/state").json()["values"] == {
            "out_1": False,
            "in_1": False,
            "out_2": True,
            "in_2": True,
        }
        # Bad writes get the runtime's error body and change nothing.
        refused = device.put("/signals/in_1", json={"value": True})
        assert refused.status_code == 422
        assert "not an output" in refused.json()["error"]["message"]
        assert device.put("/signals/out_1", json={"value": 0.5}).status_code == 422
        assert device.get("/signals/nothing").status_code == 404
        assert device.get("/state").json()["values"]["in_1"] is False


def test_the_driver_guide_s_plugin_is_listed_by_the_command(loopback: Path) -> None:
    """Installed, `openpendant driver --list` names it: here its package and a dist-info
    with the guide's entry point stand on the path as pip would leave them."""
    dist = loopback / "loopback_io-0.1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: loopback-io\nVersion: 0.1.0\n")
    (dist / "entry_points.txt").write_text(
        "[openpendant.plugins]\nloopback-io = loopback_io:PLUGIN\n"
    )
    listed = subprocess.run(
        [sys.executable, "-m", "openpendant.runtime.cli", "driver", "--list"],
        capture_output=True,
        text=True,
        check=True,
        env={"PYTHONPATH": str(loopback), "PATH": "/usr/bin:/bin"},
        cwd=loopback,
    ).stdout
    line = next(line for line in listed.splitlines() if "loopback-io" in line)
    assert "io" in line.split() and "outputs out_<n> wired to inputs in_<n>" in line


def test_the_plugin_guide_describes_the_example_plugin_as_it_is() -> None:
    """The plugin guide walks through plugins/conveyor (which browser/test_plugins.py
    installs and uses): every file its table names is there, with what it says it holds."""
    guide = (ROOT / "docs" / "dev" / "plugin.md").read_text()
    package = ROOT / "plugins" / "conveyor"
    named = re.findall(r"^\| `([^`]+)` \|", guide, re.M)
    assert len(named) == 9
    for name in named:
        top_level = name == "pyproject.toml" or name.startswith("openpendant_conveyor/")
        path = package / name if top_level else package / "openpendant_conveyor" / name
        assert path.is_file(), name
    assert 'conveyor = "openpendant_conveyor:PLUGIN"' in (package / "pyproject.toml").read_text()
    source = (package / "openpendant_conveyor" / "__init__.py").read_text()
    for declared in ("DeviceKind(", "Driver(", "Category(", "Block(", "Panel("):
        assert declared in source
    assert '"op_options": "devices:conveyor"' in source


def test_every_piece_of_the_block_guide_is_in_its_file() -> None:
    """The guide adds its block by showing what goes into each file of the category's
    folder: each piece is there, a Python one word for word, a JSON one as an entry (or,
    for words, the language's texts) with exactly those values."""
    pieces = BLOCK.findall((ROOT / "docs" / "dev" / "block.md").read_text())
    assert [path for _, path, _ in pieces] == [
        "blockly_blocks/time/blocks.json",
        "blockly_blocks/time/generator.py",
        "blockly_blocks/time/functions.py",
        "blockly_blocks/robot/blocks.json",
        "blockly_blocks/robot/functions.py",
        "blockly_blocks/robot/handlers.py",
        "blockly_blocks/time/words.json",
    ]
    for language, path, body in pieces:
        text = (ROOT / path).read_text()
        if language == "python":
            assert body in text, f"{path} lacks the guide's code"
            continue
        piece = json.loads(body)
        if path.endswith("blocks.json"):
            entry = next(e for e in json.loads(text) if e["type"] == piece["type"])
            assert {k: entry[k] for k in piece} == piece, path
        else:
            found = json.loads(text)
            for language_code, texts in piece.items():
                for block_type, words_ in texts.items():
                    assert found[language_code][block_type] == words_, path


def test_the_block_guide_s_block_generates_runs_and_stands_in_the_toolbox() -> None:
    printed = {"type": "time_since_start", "id": "since"}
    workspace = {
        "blocks": {
            "blocks": [
                {"type": "text_print", "id": "print", "inputs": {"TEXT": {"block": printed}}}
            ]
        }
    }
    generated = generate(workspace)
    assert generated.problems == []
    assert "print(seconds_since_start())" in generated.python

    async def run(pool: WorkerPool) -> list[str]:
        program = ProgramRun(
            generated.python, RecordingHost(), limits=RunLimits(wall_seconds=20), pool=pool
        )
        await program.start()
        state = await program.wait(25)
        await program.close()
        assert state is RunState.finished, program.error
        return [o.text for o in program.output]

    async def twice() -> list[str]:
        """The second run in a spare worker that waited 3 s for it."""
        pool = WorkerPool()
        try:
            await run(pool)
            assert pool._refill is not None
            await pool._refill  # the spare is there
            await asyncio.sleep(SPARE_WAITS)
            return await run(pool)
        finally:
            await pool.close()

    # Seconds since the program started, not since its worker did.
    (line,) = asyncio.run(twice())
    assert 0.0 <= float(line) < SPARE_WAITS / 3
    time_category = next(c for c in toolbox()["contents"] if c.get("toolboxitemid") == "time")
    assert {"kind": "block", "type": "time_since_start"} in time_category["contents"]
    assert words()["de"]["blocks"]["time_since_start"]["message0"] == "Sekunden seit Start"


def test_every_piece_of_the_panel_guide_is_in_its_file() -> None:
    """The panel guide walks through the I/O panel as it is: each piece it shows is in its
    file word for word (browser/test_io_panel.py uses the panel itself)."""
    pieces = BLOCK.findall((ROOT / "docs" / "dev" / "panel.md").read_text())
    assert [path for _, path, _ in pieces] == [
        "webui/frontend/src/panels/io-panel.ts",
        "webui/frontend/src/panels/io-panel.ts",
        "webui/frontend/src/panels/io-panel.ts",
        "webui/frontend/src/panels/registry.ts",
        "webui/plugin.py",
        "webui/frontend/src/i18n/en.ts",
        "webui/frontend/src/i18n/de.ts",
    ]
    for _, path, body in pieces:
        assert body in (ROOT / path).read_text(), f"{path} lacks the guide's code"
