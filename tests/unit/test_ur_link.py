"""Making a UR link: what is connected when a part of it fails (ur-rtde's classes stood in
for by fakes that record what they were asked)."""

from __future__ import annotations

from typing import Any

import dashboard_client
import pytest
import rtde_control
import rtde_receive

from openpendant.device_drivers.ur_rtde.link import URLink
from openpendant.runtime.kit.errors import RobotError


class Recorded:
    def __init__(self, monkeypatch: pytest.MonkeyPatch, model: str, control_fails: bool) -> None:
        self.events: list[str] = []
        events = self.events

        class Dashboard:
            def __init__(self, host: str) -> None:
                pass

            def connect(self) -> None:
                events.append("dashboard up")

            def getRobotModel(self) -> str:
                return model

            def polyscopeVersion(self) -> str:
                return "URSoftware 5.15.0.12345 (Jan 01 2026)"

            def disconnect(self) -> None:
                events.append("dashboard down")

        class Receive:
            def __init__(self, host: str, frequency: float) -> None:
                events.append("receive up")

            def disconnect(self) -> None:
                events.append("receive down")

        def control(host: str, frequency: float) -> Any:
            if control_fails:
                raise RuntimeError("no control script port")
            events.append("control up")
            return object()

        monkeypatch.setattr(dashboard_client, "DashboardClient", Dashboard)
        monkeypatch.setattr(rtde_receive, "RTDEReceiveInterface", Receive)
        monkeypatch.setattr(rtde_control, "RTDEControlInterface", control)


def test_another_arm_is_refused_before_rtde_is_opened(monkeypatch: pytest.MonkeyPatch) -> None:
    recorded = Recorded(monkeypatch, "UR10", control_fails=False)
    with pytest.raises(RobotError, match="not a ur5e") as refused:
        URLink("192.0.2.1", -1.0, "ur5e")
    assert refused.value.code == "wrong_model"
    assert recorded.events == ["dashboard up", "dashboard down"]


def test_a_half_made_link_leaves_nothing_connected(monkeypatch: pytest.MonkeyPatch) -> None:
    recorded = Recorded(monkeypatch, "UR5", control_fails=True)
    with pytest.raises(RuntimeError, match="no control script port"):
        URLink("192.0.2.1", -1.0, "ur5e")
    assert recorded.events == ["dashboard up", "receive up", "receive down", "dashboard down"]


def test_the_right_arm_gets_its_link(monkeypatch: pytest.MonkeyPatch) -> None:
    recorded = Recorded(monkeypatch, "UR5", control_fails=False)
    URLink("192.0.2.1", -1.0, "ur5e")
    assert recorded.events == ["dashboard up", "receive up", "control up"]
