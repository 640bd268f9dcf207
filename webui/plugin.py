"""The UI's own panels, registered through the plugin API like a plugin's. They are built
into the UI's bundle (no module to load); a plugin's panel names an ES module in its
package instead."""

from __future__ import annotations

from openpendant.plugins.api import Panel, Plugin


def _panel(id: str, order: int, en: str, de: str) -> Panel:
    return Panel(
        id=id,
        package="webui",
        module="",
        element=f"op-{id}-panel",
        title={"en": en, "de": de},
        order=order,
    )


PLUGIN = Plugin(
    name="ui",
    description="The Jog, Program, Scene, I/O, Vision, Devices, System and Users panels",
    panels=(
        _panel("jog", 10, "Jog", "Verfahren"),
        _panel("program", 20, "Program", "Programm"),
        _panel("scene", 30, "Scene", "Zelle"),
        _panel("io", 35, "I/O", "E/A"),
        _panel("vision", 37, "Vision", "Kamera"),
        _panel("devices", 40, "Devices", "Geräte"),
        _panel("system", 50, "System", "System"),
        _panel("users", 60, "Users", "Benutzer"),
    ),
)
