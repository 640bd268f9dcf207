"""The emulator from outside, for tests and benchmarks: start it in its own process, and
ask it (over its dashboard's `emulator …` lines) what happens around the robot."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from typing import Any


def start(host: str, *options: str, env: dict[str, str] | None = None) -> subprocess.Popen[str]:
    """The emulator on `host`, once it listens."""
    proc = subprocess.Popen(
        [
            sys.executable,
            "-u",
            "-m",
            "openpendant.device_drivers.ur_rtde.emulator",
            "--host",
            host,
            *options,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
    )
    assert proc.stdout is not None
    if "ready" not in proc.stdout.readline():
        proc.kill()
        raise RuntimeError(f"the UR emulator did not start on {host}")
    return proc


def stop(proc: subprocess.Popen[str]) -> None:
    proc.terminate()
    proc.communicate(timeout=10)


def world(host: str, command: str) -> str:
    """One `emulator …` line: protective stop, estop on|off, reduced on|off, digital input N
    on|off, analog input N VALUE, reset, state (all of them: `Emulator.world`)."""
    with socket.create_connection((host, 29999), timeout=5) as s:
        f = s.makefile("rw")
        f.readline()  # the greeting
        f.write(f"emulator {command}\n")
        f.flush()
        return f.readline().strip()


def place(host: str, position: list[float]) -> None:
    """Put the emulated arm at `position`, at rest (it must be still)."""
    answer = world(host, "place " + " ".join(repr(float(v)) for v in position))
    if answer != "ok":
        raise RuntimeError(f"the UR emulator did not place its arm: {answer}")


def record(host: str) -> None:
    """Start recording the emulated arm's joint positions, one per controller cycle."""
    world(host, "record on")


def recorded(host: str) -> list[list[float]]:
    """Stop recording: the joint positions recorded, one per 2 ms cycle."""
    positions: list[list[float]] = json.loads(world(host, "record off"))
    return positions


def emulated(host: str) -> dict[str, Any]:
    """The emulated controller's own state (joints, modes, commands seen, …)."""
    state: dict[str, Any] = json.loads(world(host, "state"))
    return state
