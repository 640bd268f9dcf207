"""Every installed plugin, read once per process from the entry-point group
`openpendant.plugins`. A plugin that fails to load, or that declares something another
plugin already declared, is reported (the System panel shows it) and left out; the rest
run."""

from __future__ import annotations

import importlib.metadata
import logging
import re
from dataclasses import dataclass, field
from functools import cache
from typing import Any

from openpendant.plugins.api import (
    Block,
    Category,
    DeviceKind,
    Driver,
    Panel,
    Plugin,
    Service,
    VariableType,
)

log = logging.getLogger(__name__)

GROUP = "openpendant.plugins"
CORE = "openpendant"  # the distribution whose entry points are the built-ins
NAME = re.compile(r"^[a-z][a-z0-9_-]{0,31}\Z")
KIND = re.compile(r"^[a-z][a-z0-9_]{0,15}\Z")
BLOCK_TYPE = re.compile(r"^[a-z][a-z0-9_]{0,63}\Z")


@dataclass(frozen=True)
class Failure:
    plugin: str  # the entry point's name
    source: str  # what it names, "package.module:attribute"
    error: str


@dataclass(frozen=True)
class Loaded:
    plugin: Plugin
    entry: str  # the entry point's name
    distribution: str  # the installed package it came from
    version: str
    builtin: bool


@dataclass
class Registry:
    loaded: list[Loaded] = field(default_factory=list)
    failures: list[Failure] = field(default_factory=list)
    kinds: dict[str, DeviceKind] = field(default_factory=dict)
    drivers: dict[str, Driver] = field(default_factory=dict)
    blocks: dict[str, Block] = field(default_factory=dict)
    categories: dict[str, Category] = field(default_factory=dict)
    variable_types: dict[str, VariableType] = field(default_factory=dict)
    services: dict[str, Service] = field(default_factory=dict)
    panels: dict[str, Panel] = field(default_factory=dict)
    # Which plugin declared each block, panel, driver, …: for messages and the System panel.
    owner: dict[tuple[str, str], str] = field(default_factory=dict)
    # Names blocks and services share (one sandbox function or program call may serve many
    # blocks, each declaring it with the same reference), with what each one names.
    references: dict[tuple[str, str], str] = field(default_factory=dict)

    def add(self, loaded: Loaded) -> None:
        """Add one plugin, all or nothing: a clash with what is there refuses the plugin."""
        plugin = loaded.plugin
        contributions: list[tuple[str, dict[str, Any], str, Any]] = [
            ("device kind", self.kinds, k.name, k) for k in plugin.kinds
        ]
        contributions += [("driver", self.drivers, d.name, d) for d in plugin.drivers]
        contributions += [("block", self.blocks, b.type, b) for b in plugin.blocks]
        contributions += [("category", self.categories, c.id, c) for c in plugin.categories]
        contributions += [
            ("variable type", self.variable_types, v.name, v) for v in plugin.variable_types
        ]
        contributions += [("service", self.services, s.name, s) for s in plugin.services]
        contributions += [("panel", self.panels, p.id, p) for p in plugin.panels]
        seen: set[tuple[str, str]] = set()
        for what, table, key, _ in contributions:
            if key in table or (what, key) in seen:
                holder = self.owner.get((what, key), plugin.name)
                raise ValueError(f"the {what} {key!r} is declared by {holder} already")
            seen.add((what, key))
        shared = self._shared_names(plugin)
        for what, table, key, value in contributions:
            table[key] = value
            self.owner[(what, key)] = plugin.name
        for named, reference in shared.items():
            self.references.setdefault(named, reference)
            self.owner.setdefault(named, plugin.name)
        self.loaded.append(loaded)

    def _shared_names(self, plugin: Plugin) -> dict[tuple[str, str], str]:
        """The plugin's sandbox functions, program calls and URL prefixes, checked: a name
        another declaration gives a different meaning would silently replace it."""
        named = [("sandbox function", n, r) for b in plugin.blocks for n, r in b.functions.items()]
        named += [("program call", n, r) for b in plugin.blocks for n, r in b.handlers.items()]
        named += [("URL prefix", p, s.name) for s in plugin.services for p in s.prefixes]
        found: dict[tuple[str, str], str] = {}
        for what, name, reference in named:
            if what == "sandbox function" and (not name.isidentifier() or name.startswith("_")):
                raise ValueError(
                    f"{name!r} cannot be a {what} (names starting with _ are the sandbox's)"
                )
            held = found.get((what, name), self.references.get((what, name)))
            if held is not None and held != reference:
                holder = self.owner.get((what, name), plugin.name)
                raise ValueError(f"the {what} {name!r} is declared by {holder} already")
            found[(what, name)] = reference
        return found

    def fail(self, plugin: str, source: str, error: str) -> None:
        log.warning("plugin %s (%s) left out: %s", plugin, source, error)
        self.failures.append(Failure(plugin, source, error[:500]))

    @property
    def prefixes(self) -> dict[str, str]:
        """URL prefix -> the service that owns it."""
        return {prefix: s.name for s in self.services.values() for prefix in s.prefixes}


def check(plugin: Any) -> Plugin:
    """The plugin an entry point names, checked before anything of it is used."""
    if not isinstance(plugin, Plugin):
        raise TypeError(f"the entry point names a {type(plugin).__name__}, not a Plugin")
    if not NAME.match(plugin.name):
        raise ValueError(f"plugin name {plugin.name!r}: lower case letters, digits, - and _")
    for kind in plugin.kinds:
        if not KIND.match(kind.name):
            raise ValueError(f"device kind {kind.name!r}: lower case, at most 16 characters")
    for driver in plugin.drivers:
        if not NAME.match(driver.name):
            raise ValueError(f"driver name {driver.name!r}: lower case letters, digits, -, _")
    for block in plugin.blocks:
        if not BLOCK_TYPE.match(block.type):
            raise ValueError(f"block type {block.type!r}: lower case letters, digits and _")
        if "type" in block.definition:
            raise ValueError(f"block {block.type}: its definition must not repeat 'type'")
    for service in plugin.services:
        if not NAME.match(service.name) or not all(NAME.match(p) for p in service.prefixes):
            raise ValueError(f"service {service.name!r}: bad name or URL prefix")
    for panel in plugin.panels:
        if not NAME.match(panel.id) or "-" not in panel.element:
            raise ValueError(f"panel {panel.id!r}: bad id, or an element tag without '-'")
        if panel.module.startswith("/") or ".." in panel.module.split("/"):
            raise ValueError(f"panel {panel.id!r}: the module must be inside its package")
    return plugin


def load(entries: list[importlib.metadata.EntryPoint] | None = None) -> Registry:
    """Read the plugins: the built-ins first, then the others by name."""
    if entries is None:
        entries = list(importlib.metadata.entry_points(group=GROUP))

    def distribution(entry: importlib.metadata.EntryPoint) -> tuple[str, str]:
        dist = entry.dist
        return (dist.name, dist.version) if dist is not None else ("", "")

    entries.sort(key=lambda e: (distribution(e)[0] != CORE, e.name))
    registry = Registry()
    for entry in entries:
        dist, version = distribution(entry)
        try:
            plugin = check(entry.load())
            registry.add(Loaded(plugin, entry.name, dist, version, builtin=dist == CORE))
        except Exception as exc:  # a broken plugin must not take the runtime down with it
            registry.fail(entry.name, entry.value, f"{type(exc).__name__}: {exc}")
    return registry


@cache
def registry() -> Registry:
    """This process's plugins, read on first use."""
    return load()
