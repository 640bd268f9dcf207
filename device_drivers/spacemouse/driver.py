"""The SpaceMouse driver: a thread reads the source, the latest axes and buttons are served.
If the device goes away it says so at once, and looks for it again every second."""

from __future__ import annotations

import logging
import threading
import time

import numpy as np

from openpendant.device_drivers.spacemouse.reports import AxisFilter, AxisSettings, RawInput
from openpendant.device_drivers.spacemouse.sources import DeviceGone, ReportSource
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.input import InputDriver, InputInfo, InputState

log = logging.getLogger(__name__)

REOPEN_EVERY = 1.0


class SpaceMouseDriver(InputDriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        info: InputInfo,
        source: ReportSource,
        settings: AxisSettings,
        reopen: bool = True,
    ) -> None:
        super().__init__(identity, info)
        self.source = source
        self.filter = AxisFilter(settings)
        self.reopen = reopen
        self.lock = threading.Lock()
        self.raw = np.zeros(6)
        self._state = InputState(seqno=0, ts=time.time(), axes=[0.0] * 6, connected=False)
        self._running = threading.Event()
        self._thread: threading.Thread | None = None

    def state(self) -> InputState:
        with self.lock:
            return self._state

    async def start(self) -> None:
        self._running.set()
        self._thread = threading.Thread(target=self._loop, name="spacemouse", daemon=True)
        self._thread.start()

    async def shutdown(self) -> None:
        self._running.clear()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self.source.close()

    def apply(self, raw: RawInput) -> None:
        """One input through the filter into the state (the reading thread calls this)."""
        with self.lock:
            if raw.translation is not None:
                self.raw[:3] = raw.translation
            if raw.rotation is not None:
                self.raw[3:] = raw.rotation
            buttons = sorted(raw.buttons) if raw.buttons is not None else self._state.buttons
            self._state = InputState(
                seqno=self._state.seqno + 1,
                ts=time.time(),
                axes=self.filter.apply(self.raw),
                buttons=buttons,
                connected=True,
            )

    def _gone(self, reason: str) -> None:
        with self.lock:
            self.raw[:] = 0.0
            self._state = InputState(
                seqno=self._state.seqno + 1,
                ts=time.time(),
                axes=[0.0] * 6,
                connected=False,
                error=reason,
            )

    def _loop(self) -> None:
        while self._running.is_set():
            try:
                self.source.open()
                log.info("reading %s", self.source.description)
                model = self.source.model
                if model is not None:
                    self.info.model = model.name
                    self.info.vendor_id, self.info.product_id = model.vendor_id, model.product_id
                    self.info.buttons = model.buttons
                with self.lock:
                    self._state = self._state.model_copy(update={"connected": True, "error": ""})
                while self._running.is_set():
                    raw = self.source.read(0.05)
                    if raw is not None:
                        self.apply(raw)
            except DeviceGone as exc:
                log.warning("SpaceMouse gone: %s", exc)
                self._gone(str(exc))
                self.source.close()
                if not self.reopen:
                    return
                time.sleep(REOPEN_EVERY)
