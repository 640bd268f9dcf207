"""The plugin API. A plugin is a Python package that names a `Plugin` in the entry-point group
`openpendant.plugins`; it may contribute device kinds, drivers, blocks, variable types,
services and UI panels. The built-in ones register the same way (the core's own entry
points), so a plugin can do whatever the core does.

Heavy parts are named as "module:attribute" strings and imported only by the process that
uses them (a driver's class by its driver process, a block's handler by the program
service), so declaring a plugin costs every process next to nothing."""

from __future__ import annotations

import importlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

# Words per language: {"en": {"key": "text"}, "de": {...}}.
Words = Mapping[str, Mapping[str, str]]


def resolve(reference: str) -> Any:
    """Import "package.module:attribute" (dots in the attribute walk into it)."""
    module, _, attribute = reference.partition(":")
    if not module or not attribute:
        raise ValueError(f"{reference!r} is not 'module:attribute'")
    value: Any = importlib.import_module(module)
    for part in attribute.split("."):
        value = getattr(value, part)
    return value


@dataclass(frozen=True)
class DeviceKind:
    """A kind of device: its interface (a class whose public methods carry `@endpoint`
    declarations), the state it streams, and the typed client services use."""

    name: str  # as announced in DNS-SD's `kind`: lower case, at most 16 characters
    interface: str  # "module:Class"
    state: str  # "module:Model"
    client: str  # "module:Class", a DeviceClient subclass implementing the interface
    description: str = ""
    # The device moves: the device manager holds an ordered command session on it, and the
    # driver halts when that session closes or goes silent; its state changes every control
    # cycle, so it is stale once its newest state is old (others repeat theirs at rest).
    session: bool = False
    # It carries a tool setup (TCP, payload), stored by the runtime and applied on every
    # connect, and starts at the first speed override (an arm).
    tool: bool = False
    # It streams pictures, which the device manager relays to the UI (.../frames/ws).
    frames: bool = False
    # "module:function" (driver, command log) -> APIRouter: routes the declarations cannot
    # say (a robot's command socket, a camera's frame stream).
    routes: str | None = None


@dataclass(frozen=True)
class Driver:
    """A driver: `openpendant driver NAME` runs it, and the runtime config's `devices:`
    list starts it under the launcher."""

    name: str  # "sim-robot"
    kind: str
    # "module:callable" (name: str, uuid: str, options) -> DeviceDriver
    factory: str
    options: str | None = None  # "module:Model": its settings, as flags or `options:`
    # "module:function" (driver) -> APIRouter: routes of this driver's own (a simulator's).
    routes: str | None = None
    description: str = ""
    # Its control loop needs the interpreter back within a fraction of a millisecond.
    realtime: bool = False
    # A simulation: `openpendant run --no-sim` leaves it out of the `devices:` list.
    simulated: bool = False


class RunContext(Protocol):
    """What a block's handler is given: the program run it answers for."""

    async def device(self, name: str, kind: str) -> Any:
        """The typed client of an added device, to command under the run's control lease
        (taken on first use); the run stops it when the run is stopped."""

    async def read_device(self, name: str, kind: str) -> Any:
        """The typed client of an added device, to read from (no lease needed)."""


@dataclass(frozen=True)
class Block:
    """One Blockly block, declared once: its definition, its toolbox entry, the Python it
    generates, the sandbox functions that Python calls and the runtime's answers to them."""

    type: str
    category: str  # a toolbox category's id, the core's ("robot", "io", …) or a plugin's
    definition: Mapping[str, Any]  # Blockly's JSON definition, without "type"
    generator: str  # "module:function" (block: dict, gen: Generator) -> code
    toolbox: Mapping[str, Any] | None = None  # the flyout entry (default: the bare block)
    # Names programs can call, run inside the sandbox worker: name -> "module:function".
    functions: Mapping[str, str] = field(default_factory=dict)
    # What those functions ask the runtime: call name -> "module:function", an
    # `async def handler(run: RunContext, args: dict) -> JSON value`.
    handlers: Mapping[str, str] = field(default_factory=dict)
    # Translations of the definition's texts: {"de": {"message0": …, "tooltip": …}}.
    words: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)


@dataclass(frozen=True)
class Category:
    """A toolbox category a plugin adds."""

    id: str
    name: Mapping[str, str]  # per language
    colour: str = "#5b80a5"


@dataclass(frozen=True)
class VariableType:
    name: str
    description: str
    validator: str  # "module:Model" (a pydantic model) or "module:function" (value -> value)


@dataclass(frozen=True)
class Service:
    """A service the launcher starts and supervises; the webui routes /api/<prefix>/… to it."""

    name: str
    factory: str  # "module:function" (settings, service urls) -> FastAPI
    prefixes: tuple[str, ...] = ()
    # Paths also served to browsers on a public port of the service's own.
    public_paths: tuple[str, ...] = ()


@dataclass(frozen=True)
class Panel:
    """A UI panel: an ES module, shipped in the plugin's package, that defines a custom
    element; the UI loads it when the panel is first shown (no rebuild of the core UI)."""

    id: str  # the panel's route, #/<id>
    package: str  # the Python package that holds the module
    module: str  # its path inside that package, e.g. "web/panel.js"
    element: str  # the custom element's tag
    title: Mapping[str, str]  # per language
    icon: str = ""  # an SVG path (24×24 view box)
    order: int = 100  # place in the navigation, the core's panels are 10–50


@dataclass(frozen=True)
class Plugin:
    # Also the namespace of its variables, "<name>.": programs read them but never store them.
    name: str
    description: str = ""
    kinds: Sequence[DeviceKind] = ()
    drivers: Sequence[Driver] = ()
    blocks: Sequence[Block] = ()
    categories: Sequence[Category] = ()
    variable_types: Sequence[VariableType] = ()
    services: Sequence[Service] = ()
    panels: Sequence[Panel] = ()
    # The UI's words its panels use, per language (merged into the UI's catalogue).
    words: Words = field(default_factory=dict)
