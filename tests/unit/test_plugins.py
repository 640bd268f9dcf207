"""The plugin registry: the built-ins load through it, a broken or clashing plugin is reported
and left out while the rest load, and declarations are checked before anything is used."""

from __future__ import annotations

import importlib.metadata
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from openpendant.plugins.api import Block, DeviceKind, Driver, Panel, Plugin, Service, resolve
from openpendant.plugins.registry import CORE, Loaded, check, load, registry

BUILT_IN = {"core", "drivers", "blocks", "ui"}


@pytest.fixture
def fake_plugins(tmp_path: Path) -> Iterator[Path]:
    """A folder on sys.path for plugin modules written by a test."""
    sys.path.insert(0, str(tmp_path))
    try:
        yield tmp_path
    finally:
        sys.path.remove(str(tmp_path))
        for name in [m for m in sys.modules if m.startswith("fake_plugin")]:
            del sys.modules[name]


def entry(name: str, value: str) -> importlib.metadata.EntryPoint:
    return importlib.metadata.EntryPoint(name=name, value=value, group="openpendant.plugins")


def test_the_built_ins_register_through_the_plugin_api() -> None:
    plugins = registry()
    assert {loaded.plugin.name for loaded in plugins.loaded} >= BUILT_IN
    assert all(loaded.builtin for loaded in plugins.loaded if loaded.plugin.name in BUILT_IN)
    assert {"robot", "input", "camera", "detector", "io", "gripper"} <= set(plugins.kinds)
    assert {"sim-robot", "spacemouse"} <= set(plugins.drivers)
    assert {"robot_move_joint", "io_wait_input", "program_stop"} <= set(plugins.blocks)
    assert {"variable_storage", "device_manager", "jog", "motion", "program"} <= set(
        plugins.services
    )
    assert {"jog", "program", "scene", "devices", "system"} <= set(plugins.panels)
    assert plugins.failures == []


def test_every_built_in_reference_resolves() -> None:
    plugins = registry()
    references = [k.interface for k in plugins.kinds.values()]
    references += [k.client for k in plugins.kinds.values()]
    references += [d.factory for d in plugins.drivers.values()]
    for block in plugins.blocks.values():
        references += [block.generator, *block.functions.values(), *block.handlers.values()]
    references += [s.factory for s in plugins.services.values()]
    references += [v.validator for v in plugins.variable_types.values()]
    for reference in references:
        assert resolve(reference) is not None, reference


def test_a_broken_plugin_is_reported_and_the_rest_load(fake_plugins: Path) -> None:
    (fake_plugins / "fake_plugin_raises.py").write_text("raise RuntimeError('boom')\n")
    entries = [
        entry("good", "openpendant.blockly_blocks.plugin:PLUGIN"),
        entry("missing", "fake_plugin_nowhere:PLUGIN"),
        entry("raises", "fake_plugin_raises:PLUGIN"),
        entry("not_a_plugin", "openpendant.plugins.api:resolve"),
    ]
    plugins = load(entries)
    assert [loaded.plugin.name for loaded in plugins.loaded] == ["blocks"]
    failed = {f.plugin: f.error for f in plugins.failures}
    assert set(failed) == {"missing", "raises", "not_a_plugin"}
    assert "ModuleNotFoundError" in failed["missing"]
    assert "boom" in failed["raises"]
    assert "not a Plugin" in failed["not_a_plugin"]


def test_a_plugin_that_declares_what_another_has_is_refused_whole(fake_plugins: Path) -> None:
    (fake_plugins / "fake_plugin_clash.py").write_text(
        textwrap.dedent(
            """
            from openpendant.plugins.api import Block, Driver, Plugin

            PLUGIN = Plugin(
                name="clash",
                drivers=(Driver("brand-new", "robot", "x:y"),),
                blocks=(Block("robot_home", "robot", {}, "x:y"),),
            )
            """
        )
    )
    plugins = load(
        [
            entry("a", "openpendant.blockly_blocks.plugin:PLUGIN"),
            entry("b", "fake_plugin_clash:PLUGIN"),
        ]
    )
    assert [f.plugin for f in plugins.failures] == ["b"]
    assert "robot_home" in plugins.failures[0].error
    assert "brand-new" not in plugins.drivers  # nothing of a refused plugin is kept


@pytest.mark.parametrize(
    ("block", "service", "fault"),
    [
        # A sandbox function the core's blocks give another meaning.
        (Block("x_move", "robot", {}, "a:b", functions={"move_joint": "x:y"}), None, "move_joint"),
        # A program call the core answers with another handler.
        (Block("x_move", "robot", {}, "a:b", handlers={"robot.move": "x:y"}), None, "robot.move"),
        # One of the sandbox's own guard names.
        (Block("x_get", "robot", {}, "a:b", functions={"_getattr_": "x:y"}), None, "_getattr_"),
        # A URL prefix the device manager serves.
        (None, Service("takeover", "x:y", prefixes=("devices",)), "devices"),
    ],
)
def test_a_plugin_cannot_take_over_a_name_the_core_answers(
    block: Block | None, service: Service | None, fault: str
) -> None:
    core = load(
        [
            entry("core", "openpendant.runtime.plugin:PLUGIN"),
            entry("b", "openpendant.blockly_blocks.plugin:PLUGIN"),
        ]
    )
    plugin = Plugin(
        name="takeover",
        blocks=(block,) if block else (),
        services=(service,) if service else (),
    )
    with pytest.raises(ValueError, match=fault):
        core.add(Loaded(plugin, "takeover", "takeover", "0.1", builtin=False))
    # The same function or call declared again with the same meaning is one more user of it.
    again = Block(
        "x_move",
        "robot",
        {},
        "a:b",
        handlers={"robot.move": "openpendant.blockly_blocks.robot.handlers:move"},
    )
    core.add(
        Loaded(Plugin(name="reuser", blocks=(again,)), "reuser", "reuser", "0.1", builtin=False)
    )


@pytest.mark.parametrize(
    ("plugin", "fault"),
    [
        (Plugin(name="Bad Name"), "plugin name"),
        (Plugin(name="ok", kinds=(DeviceKind("Toaster", "a:b", "a:b", "a:b"),)), "device kind"),
        (Plugin(name="ok", drivers=(Driver("no spaces", "robot", "a:b"),)), "driver name"),
        (Plugin(name="ok", blocks=(Block("x-y", "robot", {}, "a:b"),)), "block type"),
        (Plugin(name="ok", blocks=(Block("xy", "robot", {"type": "xy"}, "a:b"),)), "repeat"),
        (Plugin(name="ok", panels=(Panel("p", "pkg", "../up.js", "op-p", {}),)), "inside"),
        (Plugin(name="ok", panels=(Panel("p", "pkg", "p.js", "nodash", {}),)), "element"),
    ],
)
def test_declarations_are_checked_before_use(plugin: Plugin, fault: str) -> None:
    with pytest.raises(ValueError, match=fault):
        check(plugin)


def test_the_built_ins_come_first_whatever_the_names() -> None:
    entries = list(importlib.metadata.entry_points(group="openpendant.plugins"))
    plugins = load(list(reversed(entries)))
    names = [loaded.distribution for loaded in plugins.loaded]
    assert names[: len(BUILT_IN)] == [CORE] * len(BUILT_IN)
