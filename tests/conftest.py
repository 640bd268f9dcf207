import gc
import os
import tempfile
import time
from collections.abc import Generator
from pathlib import Path
from typing import Any

import pytest

from openpendant.runtime.bench.harness.processes import LOOPBACK_ENV, warnings_since
from openpendant.runtime.bench.harness.zygote import ENV as ZYGOTE_ENV

# Anything started from a test (directly or by the runtime) does discovery on loopback only.
os.environ.update(LOOPBACK_ENV)
# URDFs made from DH parameters are cached (runtime/robotics/dh_urdf.py): not in the user's.
os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="openpendant-test-cache-")
# The runtimes and drivers the tests start are forked from one process that has imported
# them (runtime/bench/harness/zygote.py) instead of each starting as a fresh interpreter
# (2.6 CPU-seconds of imports): the suite is about 2.5 minutes shorter.
# OPENPENDANT_TEST_ZYGOTE=0 starts each afresh.
os.environ.setdefault(ZYGOTE_ENV, "1")


@pytest.fixture
def home(tmp_path: Path) -> Path:
    """A private XDG data home, so tests never touch the user's data."""
    return tmp_path


# Unit tests that hold timing margins (a link going stale after 100 ms, leases lapsing,
# planning within a time budget, pool refills, streams at a rate): they run with the
# real-time tests, not at nice 19 beside them. test_device_connection failed there once.
TIMED_UNITS = frozenset(
    {
        "test_device_connection.py",
        "test_endpoints.py",
        "test_leases.py",
        "test_motion_search.py",
        "test_service_kit.py",
        "test_sim_core.py",
        "test_ur_silent_controller.py",
        "test_worker_pool.py",
    }
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The other unit tests run alongside the rest, and so do the browser tests, niced
    (tests/suite.py)."""
    unit = Path(__file__).parent / "unit"
    browser = Path(__file__).parent / "browser"
    for item in items:
        path = Path(item.path)
        if unit in path.parents and path.name not in TIMED_UNITS:
            item.add_marker(pytest.mark.concurrent)
        elif browser in path.parents:
            item.add_marker(pytest.mark.niced)


def pytest_collection_finish(session: pytest.Session) -> None:
    """This process keeps time itself in places (jog heartbeats against a 100 ms deadman, a
    UR driver against the RTDE watchdog): a full collection over everything collecting
    loaded took 50-170 ms here. Frozen, as the runtime's processes freeze theirs
    (runtime/kit/app.py), later collections skip it."""
    gc.collect()
    gc.freeze()


STARTED = pytest.StashKey[float]()


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    item.stash[STARTED] = time.time()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item) -> Generator[None, Any, None]:
    """A failed test's report carries what the runtime's services warned of meanwhile (a
    link gone stale, a session ended): CI keeps only the printed output, not the logs."""
    outcome = yield
    report = outcome.get_result()
    if report.failed and STARTED in item.stash:
        logged = warnings_since(item.stash[STARTED] - 1.0)
        if logged:
            report.sections.append(("service warnings during the test", "\n".join(logged)))


def pytest_sessionfinish(session: pytest.Session) -> None:
    """Collectable again, so that it all ends with the process (a frozen OMPL object left
    at exit makes nanobind report leaks)."""
    gc.unfreeze()
