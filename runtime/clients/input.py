"""An input device (a 3D mouse) over its link: its newest fresh state, or None."""

from __future__ import annotations

from typing import ClassVar

from openpendant.runtime.clients.base import DeviceClient
from openpendant.runtime.interfaces.input import InputDevice, InputState


class InputClient(DeviceClient[InputState], InputDevice):
    kind: ClassVar[str] = "input"
    state_model = InputState

    @property
    def state(self) -> InputState | None:
        return self.latest()
