import os
from pathlib import Path

import pytest

from runtime.bench.harness.processes import LOOPBACK_ENV

# Anything started from a test (directly or by the runtime) does discovery on loopback only.
os.environ.update(LOOPBACK_ENV)


@pytest.fixture
def home(tmp_path: Path) -> Path:
    """A private XDG data home, so tests never touch the user's data."""
    return tmp_path


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Unit tests hold no real-time margins: they run alongside the rest (tests/suite.py)."""
    unit = Path(__file__).parent / "unit"
    for item in items:
        if unit in Path(item.path).parents:
            item.add_marker(pytest.mark.concurrent)
