"""The parts of a simulated cell, for the 3D view: a device whose description lists the
`sim_cell` capability (the simulated robot) keeps a small world of parts on its table, and
`GET /devices/{name}/cell/parts` passes its true poses on (in the device's base frame).
A real robot has no such list: nothing pretends to know where a real part lies."""

from __future__ import annotations

from typing import Any

from pydantic import ValidationError

from openpendant.runtime.device_manager.models import CellPart
from openpendant.runtime.device_manager.registry import DeviceRegistry
from openpendant.runtime.interfaces.robot import SIM_CELL
from openpendant.runtime.kit.errors import NotFound, Unavailable

PARTS_PATH = "/sim/cell/parts"


def has_cell(info: dict[str, Any] | None) -> bool:
    described = (info or {}).get("info")
    return isinstance(described, dict) and SIM_CELL in described.get("capabilities", [])


async def cell_parts(devices: DeviceRegistry, local_name: str) -> list[CellPart]:
    conn = devices.connection(local_name)
    if not has_cell(conn.info):
        raise NotFound(f"{local_name} is not a simulated cell: it has no parts", code="no_cell")
    status, content = await conn.call("GET", PARTS_PATH, None, conn.generation)
    if status != 200 or not isinstance(content, list):
        raise Unavailable(
            f"{local_name} did not list its parts (HTTP {status})", code="device_error"
        )
    try:
        return [CellPart.model_validate(part) for part in content]
    except ValidationError as exc:
        raise Unavailable(
            f"{local_name} listed malformed parts: {exc.errors()[0]['msg']}", code="device_error"
        ) from None
