"""The Robotiq 2F-85 / 2F-140 register protocol (Robotiq's instruction manuals, "Control":
Modbus RTU, the same registers through a Modbus TCP gateway), shared by the driver and the
simulated gripper so both read the bytes the same way.

Robot output (holding registers from 1000, written with function 16): byte 0 action request
(rACT bit 0, rGTO bit 3, rATR bit 4), bytes 1-2 reserved, byte 3 position request rPR
(0 open … 255 closed), byte 4 speed rSP, byte 5 force rFR (0-255 each).
Gripper status (registers from 2000, read with function 3 or 4): byte 0 status (gACT bit 0,
gGTO bit 3, gSTA bits 4-5, gOBJ bits 6-7), byte 1 reserved, byte 2 fault (gFLT, low nibble;
kFLT, high), byte 3 position request echo, byte 4 position gPO, byte 5 current gCU (x10 mA).
Each register holds two bytes, the lower-numbered one in its high half."""

from __future__ import annotations

from dataclasses import dataclass

UNIT_ID = 9  # the factory setting
REQUEST_ADDRESS = 1000
STATUS_ADDRESS = 2000
WORDS = 3

ACT, GTO, ATR = 0x01, 0x08, 0x10

# gSTA
RESET, ACTIVATING, ACTIVE = 0, 1, 3
# gOBJ
MOVING, STOPPED_OPENING, STOPPED_CLOSING, AT_POSITION = 0, 1, 2, 3

# gFLT: what each fault means for the person at the pendant.
FAULTS: dict[int, str] = {
    0x05: "the action was delayed: activation (re-activation) must finish first",
    0x07: "activate the gripper before moving it",
    0x08: "the gripper is too hot: let it cool down",
    0x09: "no communication for at least 1 s: check the cable and the controller",
    0x0A: "supply voltage too low: check the power supply",
    0x0B: "automatic release in progress",
    0x0C: "internal fault: contact Robotiq support",
    0x0D: "activation fault: check that nothing blocks the fingers, then activate again",
    0x0E: "overcurrent: check for an obstruction, then activate again",
    0x0F: "automatic release completed: activate again",
}
# Faults that stop the gripper until it is activated again (Robotiq: "major faults").
MAJOR_FAULTS = frozenset({0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F})


@dataclass(frozen=True)
class Profile:
    model: str
    stroke: float  # m, fully open
    speed: tuple[float, float]  # m/s at rSP 0 and 255
    force: tuple[float, float]  # N at rFR 0 and 255


# Robotiq 2F-85 / 2F-140 instruction manuals, "Specifications".
PROFILES: dict[str, Profile] = {
    "robotiq-2f-85": Profile("Robotiq 2F-85", 0.085, (0.020, 0.150), (20.0, 235.0)),
    "robotiq-2f-140": Profile("Robotiq 2F-140", 0.140, (0.030, 0.250), (10.0, 125.0)),
}


@dataclass(frozen=True)
class Request:
    action: int = 0  # ACT | GTO | ATR bits
    position: int = 0  # rPR: 0 open … 255 closed
    speed: int = 0
    force: int = 0

    def words(self) -> list[int]:
        return [self.action << 8, self.position & 0xFF, (self.speed << 8) | (self.force & 0xFF)]

    @classmethod
    def of(cls, words: list[int]) -> Request:
        return cls(words[0] >> 8, words[1] & 0xFF, words[2] >> 8, words[2] & 0xFF)


@dataclass(frozen=True)
class Status:
    activated: bool = False  # gACT
    going: bool = False  # gGTO
    activation: int = RESET  # gSTA
    object: int = MOVING  # gOBJ
    fault: int = 0  # gFLT
    echo: int = 0  # gPR
    position: int = 0  # gPO
    current: int = 0  # gCU

    def words(self) -> list[int]:
        status = (
            int(self.activated)
            | (int(self.going) << 3)
            | (self.activation << 4)
            | (self.object << 6)
        )
        return [
            status << 8,
            (self.fault & 0x0F) << 8 | self.echo,
            self.position << 8 | self.current,
        ]

    @classmethod
    def of(cls, words: list[int]) -> Status:
        status = words[0] >> 8
        return cls(
            activated=bool(status & ACT),
            going=bool(status & GTO),
            activation=(status >> 4) & 0x03,
            object=(status >> 6) & 0x03,
            fault=(words[1] >> 8) & 0x0F,
            echo=words[1] & 0xFF,
            position=words[2] >> 8,
            current=words[2] & 0xFF,
        )


def fault_text(code: int) -> str:
    return FAULTS.get(code, f"fault {code:#04x}") if code else ""


def scaled(value: float, span: tuple[float, float]) -> int:
    """A speed or force in its unit as the 0-255 the gripper takes (clamped to its range)."""
    low, high = span
    return round(min(max((value - low) / (high - low), 0.0), 1.0) * 255)


def width_to_count(width: float, stroke: float) -> int:
    """An opening in m as rPR (0 fully open, 255 closed), linear over the stroke."""
    return round((1.0 - min(max(width / stroke, 0.0), 1.0)) * 255)


def count_to_width(count: int, stroke: float) -> float:
    return (1.0 - count / 255) * stroke
