"""Real Chromium (Debian's /usr/bin/chromium) driven by Playwright, against a real runtime."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from playwright.sync_api import (
    Browser,
    BrowserContext,
    CDPSession,
    ConsoleMessage,
    Locator,
    Page,
    Playwright,
    ViewportSize,
    expect,
    sync_playwright,
)

from openpendant.runtime.bench.harness.browser import CHROMIUM, CHROMIUM_ARGS
from openpendant.runtime.bench.harness.processes import Runtime, child_env, wait_for
from tests.support.autogroup import nice_new_sessions

pytestmark = pytest.mark.browser

TABLET: ViewportSize = {"width": 1280, "height": 800}
BROWSER_DEADMAN = 0.5  # seconds
BROWSER_LINK_TIMEOUT = 2.0  # seconds (tests/suite.py's niced session's)
PHONE: ViewportSize = {"width": 390, "height": 844}
# An assertion on the page waits up to 15 s, not Playwright's 5: at nice 19 beside the
# real-time tests (tests/suite.py) a page's first load waited longer than 5 s for the CPU.
expect.set_options(timeout=15_000)


@pytest.fixture(scope="package")
def playwright() -> Iterator[Playwright]:
    # Package scope, not the session's: Playwright's sync API keeps an event loop in this
    # thread while it lives, which would break asyncio.run() in any test after the browser
    # tests (they run last: pyproject.toml's testpaths).
    if not Path(CHROMIUM).is_file():
        # Browser tests must fail, never skip, when they cannot run (.ci/run installs it).
        pytest.fail(f"{CHROMIUM} is missing: install Debian's chromium package")
    with sync_playwright() as p:
        yield p


def launch(playwright: Playwright, *args: str) -> Browser:
    """Chromium, as niced as this process (tests/suite.py runs the browser tests at nice 19:
    Playwright starts the browser in a session of its own, whose niceness is its own)."""
    launched = playwright.chromium.launch(
        executable_path=CHROMIUM, headless=True, args=[*CHROMIUM_ARGS, *args]
    )
    nice_new_sessions()
    return launched


@pytest.fixture(scope="package")
def browser(playwright: Playwright) -> Iterator[Browser]:
    """One Chromium for the browser tests; every test gets fresh contexts of its own, which
    share no cookies, storage or cache (Playwright's launch gives it a fresh temporary
    profile)."""
    launched = launch(playwright)
    yield launched
    launched.close()


def open_context(browser: Browser, viewport: ViewportSize) -> BrowserContext:
    """A context of its own: no cookies, storage or cache shared with any other."""
    return browser.new_context(viewport=viewport, has_touch=True, is_mobile=viewport["width"] < 600)


def sign_in(context: BrowserContext, runtime: Runtime, role: str = "admin") -> None:
    """The context holds a signed-in session of a `role` user of `runtime` (the sign-in
    screen itself is tested in test_access.py)."""
    cookie = runtime.session_cookie(role)
    context.add_cookies([{"name": "op_session", "value": cookie, "url": runtime.url}])


def signed_in_context(
    browser: Browser, viewport: ViewportSize, request: pytest.FixtureRequest
) -> BrowserContext:
    context = open_context(browser, viewport)
    if "runtime" in request.fixturenames:
        sign_in(context, request.getfixturevalue("runtime"))
    return context


@pytest.fixture
def tablet(browser: Browser, request: pytest.FixtureRequest) -> Iterator[BrowserContext]:
    """A tablet's browser, signed in as an administrator of the test's `runtime` (if any)."""
    context = signed_in_context(browser, TABLET, request)
    yield context
    context.close()


@pytest.fixture
def phone(browser: Browser, request: pytest.FixtureRequest) -> Iterator[BrowserContext]:
    context = signed_in_context(browser, PHONE, request)
    yield context
    context.close()


def browser_env(home: Path, **extra: str) -> dict[str, str]:
    """child_env with the browser tests' deadman and link timeouts. They are widened here, not
    in the product: on this 2-core VM a software-rendered Chromium and the whole runtime share
    the cores, at nice 19 beside the real-time tests (tests/suite.py), and a heartbeat can sit
    in a run queue for over 100 ms (the 100 ms default is proven by
    tests/integration/test_jog.py); for the same reason a robot's state stream can stall past
    the 200 ms after which its link is stale (seen: a Blockly drag on a phone; the link tests
    prove the defaults)."""
    return child_env(
        home,
        OPENPENDANT_DEADMAN_SECONDS=str(BROWSER_DEADMAN),
        OPENPENDANT_LINK__STALE_AFTER=str(BROWSER_LINK_TIMEOUT),
        OPENPENDANT_LINK__DRIVER_TIMEOUT=str(BROWSER_LINK_TIMEOUT),
        **extra,
    )


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    home = tmp_path_factory.mktemp("browser")
    proc = Runtime(home, env=browser_env(home))
    proc.wait_ready()
    yield proc
    proc.stop()
    assert proc.service_errors() == []


class Finger:
    """A real touch: Chromium turns these into the same pointer events a finger makes."""

    def __init__(self, page: Page) -> None:
        self.cdp: CDPSession = page.context.new_cdp_session(page)

    def down(self, target: Locator, offset: tuple[float, float] | None = None) -> None:
        """A finger on the target's centre, or `offset` from its top-left corner."""
        target.scroll_into_view_if_needed()
        box = target.bounding_box()
        assert box is not None
        dx, dy = offset or (box["width"] / 2, box["height"] / 2)
        point = {"x": box["x"] + dx, "y": box["y"] + dy}
        self.cdp.send("Input.dispatchTouchEvent", {"type": "touchStart", "touchPoints": [point]})

    def move(self, x: float, y: float) -> None:
        self.cdp.send(
            "Input.dispatchTouchEvent", {"type": "touchMove", "touchPoints": [{"x": x, "y": y}]}
        )

    def drag(self, source: Locator, x: float, y: float, steps: int = 12) -> None:
        """Press on `source`, slide to (x, y) in steps, lift."""
        source.scroll_into_view_if_needed()
        box = source.bounding_box()
        assert box is not None
        x0, y0 = box["x"] + 10, box["y"] + box["height"] / 2
        self.cdp.send(
            "Input.dispatchTouchEvent", {"type": "touchStart", "touchPoints": [{"x": x0, "y": y0}]}
        )
        for i in range(1, steps + 1):
            self.move(x0 + (x - x0) * i / steps, y0 + (y - y0) * i / steps)
        self.up()

    def up(self) -> None:
        self.cdp.send("Input.dispatchTouchEvent", {"type": "touchEnd", "touchPoints": []})


class PageErrors:
    """Console errors and uncaught exceptions of a page: a test fails on any."""

    def __init__(self, page: Page) -> None:
        self.errors: list[str] = []
        page.on("console", self._console)
        page.on("pageerror", lambda e: self.errors.append(str(e)))

    def _console(self, message: ConsoleMessage) -> None:
        if message.type == "error":
            self.errors.append(message.text)

    def only_refusals(self) -> bool:
        """Whether every error is the server refusing a request or a socket (401 or 403)."""
        return all(any(word in e for word in REFUSALS) for e in self.errors)


# Chromium words a socket handshake answered 401 without the number.
REFUSALS = ("401", "403", "HTTP Authentication failed")


@pytest.fixture
def artifacts(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where a test leaves its screenshots."""
    return tmp_path_factory.mktemp(f"shots-{request.node.name}"[:60])


def robot_state(runtime: Runtime, name: str = "robot") -> dict[str, Any]:
    return runtime.api("GET", f"/devices/{name}/state").json()  # type: ignore[no-any-return]


def robot_joints(runtime: Runtime, name: str = "robot") -> np.ndarray[Any, Any]:
    return np.array(robot_state(runtime, name)["joint_position"])


def robot_at_rest(runtime: Runtime, name: str = "robot") -> bool:
    return bool(np.allclose(robot_state(runtime, name)["joint_velocity"], 0.0))


def add_robot(runtime: Runtime, name: str = "robot") -> str:
    """Adds the simulated robot the runtime discovers, and waits until it is connected."""
    sim = runtime.own_device()
    runtime.api("POST", "/devices", json={"uuid": sim["uuid"], "local_name": name})
    wait_for(lambda: runtime.api("GET", f"/devices/{name}").json()["status"] == "connected", 10)
    return name


def fits_the_screen(page: Page) -> bool:
    """Nothing wider than the screen. A phone browser widens the page to fit what overflows
    (window.innerWidth grows), so the check is against the device's own width."""
    width = page.viewport_size["width"] if page.viewport_size else 0
    layout: list[int] = page.evaluate("[window.innerWidth, document.documentElement.scrollWidth]")
    return bool(layout[0] == width and layout[1] <= width)
