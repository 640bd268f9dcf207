"""Control leases through the runtime's API, as two pendants would use them."""

from __future__ import annotations

import time
from pathlib import Path

from openpendant.runtime.bench.harness.processes import Runtime, child_env, wait_for


def test_control_lease_between_two_pendants(home: Path) -> None:
    runtime = Runtime(home, env=child_env(home, OPENPENDANT_LEASE_SECONDS="1.0"))
    try:
        runtime.wait_ready()
        sim = runtime.own_device()
        runtime.api("POST", "/devices", json={"uuid": sim["uuid"], "local_name": "robot"})
        assert runtime.api("POST", "/devices/nobody/lease", json={"holder": "a"}).status_code == 404

        first = runtime.api("POST", "/devices/robot/lease", json={"holder": "Pendant A"})
        assert first.status_code == 200
        token = first.json()["token"]
        refused = runtime.api("POST", "/devices/robot/lease", json={"holder": "Pendant B"})
        assert refused.status_code == 409
        assert "Pendant A" in refused.json()["error"]["message"]
        device = runtime.api("GET", "/devices").json()[0]
        assert device["controlled_by"] == "Pendant A"

        ok = runtime.api("POST", "/devices/robot/lease/check", headers={"X-Lease-Token": token})
        assert ok.status_code == 200
        forged = runtime.api(
            "POST", "/devices/robot/lease/check", headers={"X-Lease-Token": "forged"}
        )
        assert forged.json()["error"]["code"] == "lease_held"

        # Not renewed: it lapses, and the other pendant can take control.
        time.sleep(1.3)
        wait_for(
            lambda: runtime.api("GET", "/devices").json()[0]["controlled_by"] is None,
            5,
            what="lease lapsed",
        )
        second = runtime.api("POST", "/devices/robot/lease", json={"holder": "Pendant B"})
        assert second.status_code == 200
        released = runtime.api(
            "DELETE", "/devices/robot/lease", headers={"X-Lease-Token": second.json()["token"]}
        )
        assert released.status_code == 204
        assert runtime.api("GET", "/devices/robot/lease").json()["holder"] is None
    finally:
        runtime.stop()
