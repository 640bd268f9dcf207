"""A simulated camera added to a test's runtime, with its simulator's own routes."""

from __future__ import annotations

from typing import Any

import httpx
import numpy as np
from scipy.spatial.transform import Rotation

from runtime.bench.harness.processes import Runtime, wait_for
from runtime.kit.device_auth import DeviceAuth, known_secret
from runtime.kit.settings import DeviceSpec

YAML = {"Content-Type": "application/x-yaml"}


class Cam:
    """The camera added as `camera`, and its simulator's own routes (the world's side)."""

    def __init__(self, runtime: Runtime, spec: DeviceSpec) -> None:
        self.runtime = runtime
        uuid = runtime.own_device(spec)["uuid"]
        added = runtime.api("POST", "/devices", json={"uuid": uuid, "local_name": "camera"})
        assert added.status_code in (200, 201), added.text
        wait_for(
            lambda: runtime.api("GET", "/devices/camera").json()["status"] == "connected",
            30,
            what="the camera connected",
        )
        device = runtime.api("GET", "/devices/camera").json()
        secret = known_secret(runtime.data_dir, device["uuid"])
        self.sim = httpx.Client(
            base_url=device["url"], timeout=10, auth=DeviceAuth(secret) if secret else None
        )
        self.truth: dict[str, Any] = self.sim.get("/sim/truth").json()
        pose = self.truth["camera"]["pose"]
        self.pose = np.eye(4)
        self.pose[:3, :3] = Rotation.from_quat(pose["orientation"]).as_matrix()
        self.pose[:3, 3] = pose["position"]

    def put_board(self, pose: dict[str, Any] | None) -> None:
        answer = self.sim.put("/sim/board", json={"pose": pose})
        assert answer.status_code == 200, answer.text
