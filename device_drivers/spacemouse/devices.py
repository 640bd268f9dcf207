"""The 3Dconnexion devices this driver knows, by USB vendor and product id.

Two report layouts exist. Older models send translation and rotation in separate 7-byte
reports (id 1 and id 2, three little-endian int16 each); newer ones send one 13-byte report
(id 1, all six). Buttons come in report 3 as a bit mask. The parser tells the layouts apart
by length, so a model missing here still works; the table names what is supported."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

LOGITECH = 0x046D  # the older 3Dconnexion models carry Logitech's vendor id
THREEDCONNEXION = 0x256F


@dataclass(frozen=True)
class SpaceMouseModel:
    name: str
    vendor_id: int
    product_id: int
    layout: Literal["separate", "combined"]
    buttons: int


MODELS = (
    SpaceMouseModel("SpaceNavigator", LOGITECH, 0xC626, "separate", 2),
    SpaceMouseModel("SpaceExplorer", LOGITECH, 0xC627, "separate", 15),
    SpaceMouseModel("SpacePilot Pro", LOGITECH, 0xC629, "separate", 31),
    SpaceMouseModel("SpaceMouse Pro", LOGITECH, 0xC62B, "separate", 15),
    SpaceMouseModel("SpaceMouse Wireless (cable)", THREEDCONNEXION, 0xC62E, "combined", 2),
    SpaceMouseModel("SpaceMouse Wireless (receiver)", THREEDCONNEXION, 0xC62F, "combined", 2),
    SpaceMouseModel("SpaceMouse Pro Wireless (cable)", THREEDCONNEXION, 0xC631, "combined", 15),
    SpaceMouseModel("SpaceMouse Pro Wireless (receiver)", THREEDCONNEXION, 0xC632, "combined", 15),
    SpaceMouseModel("SpaceMouse Enterprise", THREEDCONNEXION, 0xC633, "combined", 31),
    SpaceMouseModel("SpaceMouse Compact", THREEDCONNEXION, 0xC635, "separate", 2),
    SpaceMouseModel("3Dconnexion Universal Receiver", THREEDCONNEXION, 0xC652, "combined", 31),
)

BY_ID = {(m.vendor_id, m.product_id): m for m in MODELS}


def find_model(vendor_id: int, product_id: int) -> SpaceMouseModel | None:
    return BY_ID.get((vendor_id, product_id))
