"""The example plugin (plugins/conveyor) is one package: everything it adds — a device kind, its
driver, two blocks, a panel — lives in its own folder, and the core does not know it exists.
Its simulated conveyor brings parts to the sensor and holds them there."""

from __future__ import annotations

import asyncio
import importlib
import inspect
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
PLUGIN_DIR = ROOT / "plugins" / "conveyor"
PACKAGE = PLUGIN_DIR / "openpendant_conveyor"
CORE = ("runtime", "device_drivers", "sandbox", "blockly_blocks", "webui", "deploy", "plugins")


@pytest.fixture(scope="module")
def conveyor() -> Iterator[ModuleType]:
    """The plugin as its source folder has it (installed or not)."""
    sys.path.insert(0, str(PLUGIN_DIR))
    try:
        yield importlib.import_module("openpendant_conveyor")
    finally:
        sys.path.remove(str(PLUGIN_DIR))


def references(plugin: Any) -> list[str]:
    found = [k.interface for k in plugin.kinds] + [k.state for k in plugin.kinds]
    found += [k.client for k in plugin.kinds]
    for driver in plugin.drivers:
        found += [driver.factory, driver.options or "", driver.routes or ""]
    for block in plugin.blocks:
        found += [block.generator, *block.functions.values(), *block.handlers.values()]
    return [r for r in found if r]


def test_everything_the_plugin_adds_lives_in_its_own_package(conveyor: ModuleType) -> None:
    plugin = conveyor.PLUGIN
    assert [k.name for k in plugin.kinds] == ["conveyor"]
    assert [d.name for d in plugin.drivers] == ["sim-conveyor"]
    assert {b.type for b in plugin.blocks} == {"conveyor_run", "conveyor_wait_part"}
    assert [p.id for p in plugin.panels] == ["conveyor"]
    for reference in references(plugin):
        module, _, attribute = reference.partition(":")
        found = getattr(importlib.import_module(module), attribute)
        source = Path(inspect.getfile(importlib.import_module(module)))
        assert source.is_relative_to(PACKAGE), f"{reference} is outside the plugin"
        assert found is not None
    for panel in plugin.panels:
        assert (PACKAGE / panel.module).is_file()


def test_the_plugins_files_are_its_own_and_the_core_never_names_it() -> None:
    tracked = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    own = [f for f in tracked if f.startswith("plugins/conveyor/")]
    assert {
        "plugins/conveyor/pyproject.toml",
        "plugins/conveyor/openpendant_conveyor/__init__.py",
        "plugins/conveyor/openpendant_conveyor/sim.py",
        "plugins/conveyor/openpendant_conveyor/web/panel.js",
    } <= set(own)
    core = [f for f in tracked if f.startswith(CORE) and not f.startswith("plugins/conveyor/")]
    naming = [f for f in core if "conveyor" in (ROOT / f).read_text(errors="ignore").lower()]
    assert naming == [], "the core names the example plugin"


def test_the_simulated_belt_brings_parts_to_the_sensor_and_holds_them(
    conveyor: ModuleType,
) -> None:
    sim = importlib.import_module("openpendant_conveyor.sim")
    interface = importlib.import_module("openpendant_conveyor.interface")
    options = sim.SimConveyorOptions(length=1.0, max_speed=0.5, sensor_at=0.5, spacing=0.2)
    belt = sim.create("belt", "belt-uuid", options)
    with pytest.raises(Exception, match="over the conveyor"):
        asyncio.run(belt.run(interface.SpeedCommand(speed=0.6)))
    asyncio.run(belt.run(interface.SpeedCommand(speed=0.5)))
    for _ in range(200):  # 4 s at 50 Hz
        belt.step(0.02)
    state = belt.state()
    assert state.part_present and abs(state.speed - 0.5) < 1e-9
    # Parts queue behind the one at the stopper, a part's length apart, never overlapping.
    gaps = [a - b for a, b in zip(belt.parts, belt.parts[1:], strict=False)]
    assert belt.parts[0] == pytest.approx(0.5) and all(g >= sim.PART - 1e-9 for g in gaps)
    taken = belt.take()
    assert taken.parts_taken == 1
    for _ in range(50):
        belt.step(0.02)
    assert belt.state().part_present  # the next one moved up
    asyncio.run(belt.stop())
    for _ in range(50):
        belt.step(0.02)
    assert belt.state().speed == 0.0


def test_the_plugins_words_are_complete_in_every_language(conveyor: ModuleType) -> None:
    """Like the UI's own catalogues: a translation has every key of the English, no more."""
    plugin = conveyor.PLUGIN
    english = set(plugin.words["en"])
    for language, words in plugin.words.items():
        assert set(words) == english, language
    for block in plugin.blocks:
        for language, words in block.words.items():
            assert {"message0", "tooltip"} <= set(words), (block.type, language)
            # The same %1, %2… as the English message, in any order.
            placeholders = set(re.findall(r"%\d", block.definition["message0"]))
            assert set(re.findall(r"%\d", words["message0"])) == placeholders
    for category in plugin.categories:
        assert set(category.name) == set(plugin.words)
    for panel in plugin.panels:
        assert set(panel.title) == set(plugin.words)
