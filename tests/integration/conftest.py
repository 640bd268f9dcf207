from collections.abc import Iterator
from pathlib import Path

import pytest

from openpendant.runtime.bench.harness.processes import SimRobotProc

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SimRobotProc]:
    """One standalone simulated UR5, shared by a module's tests."""
    home: Path = tmp_path_factory.mktemp("sim")
    proc = SimRobotProc(home, name="it-ur5")
    proc.wait_ready()
    yield proc
    proc.stop()
