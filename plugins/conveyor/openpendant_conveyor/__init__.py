"""An example OpenPendant plugin: a conveyor. Everything it adds is declared here; the parts
are named as "module:attribute" and loaded only by the process that needs them."""

from __future__ import annotations

from openpendant.plugins.api import Block, Category, DeviceKind, Driver, Panel, Plugin

P = "openpendant_conveyor"

NAME_FIELD = {
    "type": "field_dropdown",
    "name": "CONVEYOR",
    "options": [["belt", "belt"]],
    "op_options": "devices:conveyor",
}

PLUGIN = Plugin(
    name="conveyor",
    description="A conveyor: its device kind, a simulated one, two blocks and a panel",
    kinds=(
        DeviceKind(
            "conveyor",
            f"{P}.interface:Conveyor",
            f"{P}.interface:ConveyorState",
            f"{P}.client:ConveyorClient",
            "a conveyor belt with a part sensor",
        ),
    ),
    drivers=(
        Driver(
            "sim-conveyor",
            "conveyor",
            f"{P}.sim:create",
            options=f"{P}.sim:SimConveyorOptions",
            routes=f"{P}.sim:routes",
            description="a simulated conveyor that brings parts to a stopper with a sensor",
            simulated=True,
        ),
    ),
    categories=(Category("conveyor", {"en": "Conveyor", "de": "Förderband"}, colour="#2f8f6f"),),
    blocks=(
        Block(
            type="conveyor_run",
            category="conveyor",
            definition={
                "message0": "run conveyor %1 at %2 mm/s",
                "args0": [NAME_FIELD, {"type": "input_value", "name": "SPEED", "check": "Number"}],
                "inputsInline": True,
                "previousStatement": None,
                "nextStatement": None,
                "colour": "#2f8f6f",
                "tooltip": "Run the belt at this speed (0 stops it; negative runs it back).",
            },
            toolbox={
                "kind": "block",
                "type": "conveyor_run",
                "inputs": {"SPEED": {"shadow": {"type": "math_number", "fields": {"NUM": 100}}}},
            },
            generator=f"{P}.blocks:conveyor_run",
            functions={"run_conveyor": f"{P}.program:run_conveyor"},
            handlers={"conveyor.run": f"{P}.handlers:run"},
            words={
                "de": {
                    "message0": "Förderband %1 mit %2 mm/s fahren",
                    "tooltip": "Das Band mit dieser Geschwindigkeit fahren (0 hält es an).",
                }
            },
        ),
        Block(
            type="conveyor_wait_part",
            category="conveyor",
            definition={
                "message0": "wait for a part on %1 %2 at most %3 s",
                "args0": [
                    NAME_FIELD,
                    {"type": "input_end_row"},
                    {"type": "input_value", "name": "TIMEOUT", "check": "Number"},
                ],
                "inputsInline": True,
                "previousStatement": None,
                "nextStatement": None,
                "colour": "#2f8f6f",
                "tooltip": "Wait until a part is at the conveyor's sensor; fail after the timeout.",
            },
            toolbox={
                "kind": "block",
                "type": "conveyor_wait_part",
                "inputs": {"TIMEOUT": {"shadow": {"type": "math_number", "fields": {"NUM": 10}}}},
            },
            generator=f"{P}.blocks:conveyor_wait_part",
            functions={
                "wait_for_part": f"{P}.program:wait_for_part",
                "part_waiting": f"{P}.program:part_waiting",
            },
            handlers={"conveyor.part": f"{P}.handlers:part"},
            words={
                "de": {
                    "message0": "auf ein Teil an %1 warten %2 höchstens %3 s",
                    "tooltip": "Warten, bis ein Teil am Sensor ist; Fehler nach der Zeit.",
                }
            },
        ),
    ),
    panels=(
        Panel(
            id="conveyor",
            package=P,
            module="web/panel.js",
            element="op-conveyor-panel",
            title={"en": "Conveyor", "de": "Band"},
            icon="M3 15h18v3H3zM6 9h5v5H6zM13 10h4v4h-4zM5 19a1 1 0 1 0 2 0M17 19a1 1 0 1 0 2 0",
            order=45,
        ),
    ),
    words={
        "en": {
            "title": "Conveyors",
            "none": "No conveyor is added. Add one in the Devices panel.",
            "speed": "Speed",
            "travel": "Belt travel",
            "part": "Part at the sensor",
            "no_part": "No part at the sensor",
            "run": "Run",
            "back": "Back",
            "stop": "Stop",
            "take": "Take control",
            "release": "Release",
            "controlled_by": "Controlled by {holder}",
            "offline": "Not connected",
            "take_part": "Take the part",
        },
        "de": {
            "title": "Förderbänder",
            "none": "Kein Förderband hinzugefügt. Im Bereich Geräte hinzufügen.",
            "speed": "Geschwindigkeit",
            "travel": "Bandweg",
            "part": "Teil am Sensor",
            "no_part": "Kein Teil am Sensor",
            "run": "Fahren",
            "back": "Zurück",
            "stop": "Halt",
            "take": "Steuerung übernehmen",
            "release": "Freigeben",
            "controlled_by": "Gesteuert von {holder}",
            "offline": "Nicht verbunden",
            "take_part": "Teil entnehmen",
        },
    },
)
