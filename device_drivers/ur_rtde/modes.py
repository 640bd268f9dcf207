"""The pendant's operational mode, asked of the controller's dashboard every second on a
connection and a thread of their own: a dashboard that hangs (it answers within ur-rtde's
2.5 s read timeout, or not at all) must not hold up the control thread, whose silence the
RTDE watchdog would punish by stopping the arm."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

import dashboard_client

log = logging.getLogger(__name__)

MODE_POLL = 1.0  # s between two questions (the mode changes by hand, on the pendant)


def ask(dashboard: Any) -> str:
    """`get operational mode`: MANUAL, AUTOMATIC, or NONE where the controller has no mode
    selection (and on PolyScope before 5.6, which has no command for it)."""
    dashboard.send("get operational mode\n")
    answer = str(dashboard.receive()).strip().upper()
    return answer if answer in ("MANUAL", "AUTOMATIC") else "NONE"


class ModeWatch:
    """Calls `seen(mode)` with every answer while `wanted()` (the driver has its link: no
    connection attempts to a controller that cannot be reached); reconnects by itself."""

    def __init__(self, host: str, seen: Callable[[str], None], wanted: Callable[[], bool]) -> None:
        self.host, self.seen, self.wanted = host, seen, wanted
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="ur-mode", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def close(self, timeout: float = 3.0) -> None:
        self._stop.set()
        self._thread.join(timeout)

    def _run(self) -> None:
        dashboard: Any = None
        failing = False
        while not self._stop.is_set():
            if not self.wanted():
                _dropped(dashboard)
                dashboard = None
                self._stop.wait(MODE_POLL)
                continue
            try:
                if dashboard is None:
                    dashboard = dashboard_client.DashboardClient(self.host)
                    dashboard.connect()
                self.seen(ask(dashboard))
                failing = False
            except Exception as exc:  # the next round connects afresh
                if not failing:
                    log.warning("operational mode not read: %s", exc)
                failing = True
                _dropped(dashboard)
                dashboard = None
            self._stop.wait(MODE_POLL)
        _dropped(dashboard)


def _dropped(dashboard: Any) -> None:
    if dashboard is not None:
        try:
            dashboard.disconnect()
        except Exception as exc:  # gone already
            log.debug("dashboard disconnect: %s", exc)
