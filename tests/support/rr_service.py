"""One of the RR test services (tests/support/rr_sim_arm.py, rr_sim_camera.py,
rr_sim_tool.py) in a process of its own on 127.0.0.1, and an RR client's calls to its test
parameters."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import RobotRaconteur as RR

from openpendant.plugins.robotraconteur.node import Node
from openpendant.runtime.bench.harness.processes import free_port

REPOSITORY = Path(__file__).resolve().parents[2]


class RRService:
    """`python -m tests.support.MODULE PORT [ARGS]`, serving `service`, once it says READY."""

    def __init__(self, module: str, service: str, *args: str, port: int | None = None) -> None:
        self.port = free_port() if port is None else port
        self.url = f"rr+tcp://127.0.0.1:{self.port}?service={service}"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", f"tests.support.{module}", str(self.port), *args],
            cwd=REPOSITORY,
            stdout=subprocess.PIPE,
            text=True,
            # Started again on the same port by the tests of a service lost and back.
            env={**os.environ, "ROBOTRACONTEUR_TCP_SERVER_REUSEADDR": "1"},
        )
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        assert line.strip() == "READY", f"{module} did not start: {line!r}"

    def set(self, name: str, value: Any, kind: str) -> None:
        """One of its test parameters, over RR as any client would."""
        node = Node()
        try:
            node.connect(self.url).setf_param(name, RR.VarValue(value, kind))
        finally:
            node.close()

    def get(self, name: str) -> Any:
        node = Node()
        try:
            return node.connect(self.url).getf_param(name).data
        finally:
            node.close()

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.kill()
