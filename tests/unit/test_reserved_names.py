"""The names a program may read but never store (issue 32: a program's
`store('frames.robot', pose(500, 0, 0))` broke every later move of the robot)."""

from __future__ import annotations

import pytest

from openpendant.plugins.api import Plugin
from openpendant.plugins.registry import Loaded, Registry, registry
from openpendant.runtime.program.reserved_names import RUNTIME_NAMESPACES, refuse_reserved
from openpendant.sandbox.supervisor import CallRefused

PREFIXES = ("frames.", "calibration.", "tools.", "detectors.", "program.", "vision.", "devices.")


def test_the_runtimes_namespaces_are_reserved() -> None:
    assert {n.prefix for n in RUNTIME_NAMESPACES} == set(PREFIXES)


@pytest.mark.parametrize("prefix", [*PREFIXES, *(f"{p.plugin.name}." for p in registry().loaded)])
def test_a_reserved_name_is_refused_saying_who_changes_it(prefix: str) -> None:
    with pytest.raises(CallRefused) as refused:
        refuse_reserved(f"{prefix}robot")
    assert refused.value.code == "reserved_name"
    message = refused.value.message
    assert message.startswith(f"{prefix}robot is reserved: names under {prefix} ")
    assert "a program may read but not change" in message
    assert "programmer changes them in the" in message or "administrator changes" in message


def test_each_plugins_name_is_its_namespace_loaded_or_not(monkeypatch: pytest.MonkeyPatch) -> None:
    plugins = Registry()
    plugins.add(Loaded(Plugin(name="conveyor"), "conveyor", "openpendant-conveyor", "1", False))
    plugins.fail("broken", "broken_plugin:PLUGIN", "ImportError")
    monkeypatch.setattr("openpendant.runtime.program.reserved_names.registry", lambda: plugins)
    for name in ("conveyor.speed", "broken.x"):
        with pytest.raises(CallRefused, match="plugin's variables"):
            refuse_reserved(name)
    refuse_reserved("blocks.x")  # not installed here


@pytest.mark.parametrize("name", ["frames", "framesx.a", "frame.robot", "my.frames.x", "Frames.x"])
def test_names_outside_the_namespaces_are_a_programs(name: str) -> None:
    refuse_reserved(name)
