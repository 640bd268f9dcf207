"""Variable names a program may read but never store: the runtime's own namespaces and each
plugin's (`<plugin name>.`). What lives there is set up in the runtime's panels or through
the API by the role the policy table gives; a program that wrote a pose to `frames.robot`
broke every later move of that robot."""

from __future__ import annotations

from dataclasses import dataclass

from openpendant.plugins.registry import registry
from openpendant.runtime.kit.words import words
from openpendant.sandbox.supervisor import CallRefused


@dataclass(frozen=True)
class Namespace:
    prefix: str
    holds: str
    changed_by: str  # who changes it, and where


RUNTIME_NAMESPACES = (
    Namespace(
        "frames.",
        "the robots' and cameras' frames",
        "a programmer changes them in the Scene panel (a robot's mounting) or the Vision panel "
        "(a camera's place)",
    ),
    Namespace(
        "calibration.",
        "the cameras' calibrations",
        "a programmer changes them in the Vision panel",
    ),
    Namespace("tools.", "the robots' tool set-ups", "a programmer changes them in the Scene panel"),
    Namespace(
        "detectors.", "the object detectors", "a programmer changes them in the Vision panel"
    ),
    Namespace("program.", "the programs", "a programmer changes them in the Program panel"),
    Namespace("vision.", "the vision settings", "a programmer changes them in the Vision panel"),
    Namespace(
        "devices.", "the added devices", "an administrator changes them in the Devices panel"
    ),
)


def plugin_namespaces() -> tuple[Namespace, ...]:
    """One per installed plugin, loaded or not (one that failed to load keeps its names)."""
    found = registry()
    names = {loaded.plugin.name for loaded in found.loaded}
    names |= {failure.plugin for failure in found.failures}
    return tuple(
        Namespace(
            f"{name}.",
            f"the {name} plugin's variables",
            "a programmer changes them in the plugin's panel",
        )
        for name in sorted(names)
    )


def namespace_of(name: str) -> Namespace | None:
    for namespace in (*RUNTIME_NAMESPACES, *plugin_namespaces()):
        if name.startswith(namespace.prefix):
            return namespace
    return None


def refuse_reserved(name: str) -> None:
    namespace = namespace_of(name)
    if namespace is not None:
        raise CallRefused(
            f"{name} is reserved: names under {namespace.prefix} are {namespace.holds}, which "
            f"a program may read but not change; {namespace.changed_by} or through the API",
            "reserved_name",
            words("storage.reserved", name=name, prefix=namespace.prefix),
        )
