"""What was checked is what is executed, on a UR (issue 31): fast linear moves planned in
automatic mode at full speed, streamed by the UR driver (servoJ through ur-rtde) to the
controller emulator, keep the emulated arm's TCP on their straight line, measured on the
emulator's own joint positions every 2 ms cycle. (The emulator ran each servoJ target to
rest on every joint's own profile: up to 27 mm off the line.)"""

from __future__ import annotations

import asyncio
import subprocess
from collections.abc import Iterator

import pytest

from openpendant.device_drivers.ur_rtde.emulator import control as emulator_control
from openpendant.runtime.bench.bench_ur import linear_deviations

HOST = "127.0.0.7"
BOUND = 2e-3  # m: the figure path_deviation_ur_max_mm is held to (issue 31)


@pytest.fixture(scope="module")
def emulator() -> Iterator[subprocess.Popen[str]]:
    proc = emulator_control.start(HOST)
    yield proc
    emulator_control.stop(proc)


def test_fast_linear_moves_through_the_ur_driver_stay_on_their_line(
    emulator: subprocess.Popen[str],
) -> None:
    # One direction (0.6 m across) and the move out to the edge of the arm's reach.
    deviations = asyncio.run(linear_deviations(HOST, limit=1))
    assert len(deviations) == 2
    off = {what: round(d * 1000, 3) for what, d in deviations.items()}
    assert max(deviations.values()) < BOUND, f"mm off the line: {off}"
