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
