"""Signing in on a tablet by touch, over HTTPS: the first start's set-up of the
administrator (with the runtime's certificate authority to trust, its fingerprint and QR
code), an operator refused the administrator's page, hostile text shown as text, signing
out, a tablet whose session ended elsewhere saying why on its sign-in screen, plain HTTP sent
on to HTTPS, and a jog over the jog port's TLS.

This module's runtime speaks HTTPS only (`run --tls`, its own certificate authority, plain
HTTP on a port of its own redirected); Chromium trusts the authority by its public key's
SHA-256 (--ignore-certificate-errors-spki-list), as a tablet that installed it would. Every
other module's runtime speaks plain HTTP."""

from __future__ import annotations

import ssl
from collections.abc import Iterator
from pathlib import Path

import cv2
import httpx
import numpy as np
import pytest
import yaml
from playwright.sync_api import Browser, Page, Playwright, expect

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.setup import auth_path
from openpendant.runtime.auth.store import AuthStore
from openpendant.runtime.bench.harness.processes import Runtime, SimRobotProc, free_port, wait_for
from openpendant.runtime.kit.tls import (
    CA_CERT,
    CA_DOWNLOAD,
    SERVER_CERT,
    SERVER_KEY,
    TLS_DIR,
    TlsFiles,
)
from tests.browser.conftest import (
    TABLET,
    Finger,
    PageErrors,
    add_robot,
    browser_env,
    launch,
    open_context,
    robot_at_rest,
    robot_joints,
)
from tests.browser.test_shop_floor import take_control_and_enable

HOSTILE = '<img src=x onerror="window.__pwned=1">'


def authority(runtime: Runtime) -> TlsFiles:
    folder = runtime.data_dir / TLS_DIR
    return TlsFiles(folder / SERVER_CERT, folder / SERVER_KEY, folder / CA_CERT)


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    home = tmp_path_factory.mktemp("access-tls")
    config = home / "config.yaml"
    config.write_text(f"tls:\n  redirect_port: {free_port()}\n")
    proc = Runtime(home, extra=["--tls", "--config", str(config)], env=browser_env(home))
    proc.wait_ready()
    yield proc
    proc.stop()
    assert proc.service_errors() == []


@pytest.fixture(scope="module")
def browser(playwright: Playwright, runtime: Runtime) -> Iterator[Browser]:
    """Chromium trusting this runtime's certificate authority, and nothing else new."""
    pin = f"--ignore-certificate-errors-spki-list={authority(runtime).spki_pin()}"
    launched = launch(playwright, pin)
    yield launched
    launched.close()


def redirect_port(runtime: Runtime) -> int:
    line = runtime.wait_line(lambda s: "Plain HTTP on port" in s, 5)
    return int(line.split("Plain HTTP on port", 1)[1].split()[0])


def decoded_qr(png: bytes) -> str:
    """What an independent reader (OpenCV's) reads in a screenshot of a QR code."""
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_GRAYSCALE)
    assert image is not None
    text, _, _ = cv2.QRCodeDetector().detectAndDecode(image)
    return str(text)


def sign_in_by_touch(page: Page, user: str, password: str) -> None:
    form = page.get_by_test_id("sign-in")
    expect(form).to_be_visible()
    page.get_by_test_id("sign-in-user").tap()
    page.get_by_test_id("sign-in-user").fill(user)
    page.get_by_test_id("sign-in-password").tap()
    page.get_by_test_id("sign-in-password").fill(password)
    page.get_by_test_id("sign-in-submit").tap()


def sign_out_by_touch(page: Page) -> None:
    page.get_by_test_id("nav-system").tap()
    page.get_by_test_id("sign-out").tap()
    expect(page.get_by_test_id("sign-in")).to_be_visible()


def test_the_first_start_sets_up_the_administrator_by_touch(
    runtime: Runtime, browser: Browser
) -> None:
    """Before anyone signs in (no user exists yet in this module's runtime)."""
    context = open_context(browser, TABLET)
    try:
        page = context.new_page()
        errors = PageErrors(page)
        assert runtime.url.startswith("https://")
        page.goto(runtime.url)
        expect(page.get_by_test_id("sign-in")).to_contain_text("Set up OpenPendant")
        # What a tablet checks before it trusts this runtime: its authority's fingerprint,
        # and the authority itself behind a link and a QR code of the link.
        files = authority(runtime)
        expect(page.get_by_test_id("tls-fingerprint")).to_have_text(files.fingerprint())
        download = f"{runtime.url}{CA_DOWNLOAD}"
        assert decoded_qr(page.get_by_test_id("tls-qr").screenshot()) == download
        expect(page.get_by_test_id("tls-download")).to_have_attribute("href", download)
        fetched = page.evaluate("(url) => fetch(url).then((r) => r.text())", download)
        assert files.ca is not None and fetched == files.ca.read_text()
        # From loopback no set-up code is asked for; the passwords must agree.
        expect(page.get_by_test_id("sign-in-code")).to_have_count(0)
        page.get_by_test_id("sign-in-user").fill("ada")
        page.get_by_test_id("sign-in-password").fill("correct horse battery")
        page.get_by_test_id("sign-in-repeat").fill("correct horse batterx")
        page.get_by_test_id("sign-in-submit").tap()
        expect(page.get_by_test_id("sign-in-error")).to_contain_text("differ")
        page.get_by_test_id("sign-in-repeat").fill("correct horse battery")
        page.get_by_test_id("sign-in-submit").tap()
        expect(page.get_by_test_id("nav-users")).to_be_visible()
        page.get_by_test_id("nav-users").tap()
        expect(page.locator("[data-testid=user][data-name=ada]")).to_be_visible()
        sign_out_by_touch(page)
        expect(page.get_by_test_id("sign-in")).to_contain_text("Sign in")
        assert runtime.api("GET", "/auth/status", role=None).json()["set_up"] is True
        assert errors.only_refusals(), "\n".join(errors.errors)
    finally:
        context.close()


def test_an_operator_is_refused_the_administrators_page(runtime: Runtime, browser: Browser) -> None:
    name, password = runtime.user("operator")
    context = open_context(browser, TABLET)
    try:
        page = context.new_page()
        page.goto(runtime.url)
        sign_in_by_touch(page, name, "not the password")
        expect(page.get_by_test_id("sign-in-error")).to_contain_text("wrong")
        sign_in_by_touch(page, name, password)
        expect(page.get_by_test_id("nav-jog")).to_be_visible()
        expect(page.get_by_test_id("nav-users")).to_have_count(0)
        page.goto(f"{runtime.url}/#/users")
        expect(page.get_by_test_id("admin-only")).to_be_visible()
        expect(page.get_by_test_id("users")).to_have_count(0)
        # What the page does not show, the runtime refuses as well.
        csrf = page.evaluate("fetch('/api/auth/me').then((r) => r.json()).then((me) => me.csrf)")
        status = page.evaluate(
            """(csrf) => fetch('/api/auth/users', {method: 'POST',
                 headers: {'content-type': 'application/json', 'x-csrf-token': csrf},
                 body: JSON.stringify({name: 'eve', role: 'admin', password: 'x'.repeat(12),
                                       confirm_password: 'x'.repeat(12)})})
               .then((r) => r.status)""",
            csrf,
        )
        assert status == 403
        sign_out_by_touch(page)
        page.goto(f"{runtime.url}/#/jog")
        expect(page.get_by_test_id("sign-in")).to_be_visible()  # the session is gone
    finally:
        context.close()


def test_hostile_names_and_text_are_shown_as_text(
    runtime: Runtime, browser: Browser, tmp_path: Path
) -> None:
    sim = SimRobotProc(tmp_path, name=HOSTILE)
    context = open_context(browser, TABLET)
    try:
        sim.wait_ready()
        # Names of programs and variables are names only: the runtime refuses the markup.
        for path in ("/programs/%3Cimg%20src%3Dx%3E", "/variables/%3Cimg%20src%3Dx%3E"):
            refused = runtime.api("PUT", path, json={"python": "x = 1"})
            assert refused.status_code in (400, 422), path
        printed = runtime.api("PUT", "/programs/shout", json={"python": f"print({HOSTILE!r})"})
        assert printed.status_code == 200
        run = runtime.api("POST", "/programs/shout/run", json={})
        assert run.status_code == 202
        wait_for(
            lambda: runtime.api("GET", "/programs/shout/status").json()["state"] == "finished",
            30,
        )
        name, password = runtime.user("programmer")
        page = context.new_page()
        page.goto(f"{runtime.url}/#/devices")
        sign_in_by_touch(page, name, password)
        card = page.get_by_test_id("detected-device").filter(has_text=HOSTILE)
        expect(card).to_be_visible(timeout=15_000)
        page.goto(f"{runtime.url}/#/program")
        page.get_by_test_id("program-select").select_option("shout")
        expect(page.get_by_test_id("output")).to_contain_text(HOSTILE, timeout=15_000)
        assert page.evaluate("window.__pwned") is None
        assert page.locator("img[src=x]").count() == 0
    finally:
        context.close()
        sim.stop()


def test_an_administrator_changes_a_users_role_and_pin_by_touch(
    runtime: Runtime, browser: Browser
) -> None:
    admin, admin_password = runtime.user("admin")
    operator, _ = runtime.user("operator")

    def listed() -> dict[str, tuple[str, bool]]:
        users = runtime.api("GET", "/auth/users").json()
        return {u["name"]: (u["role"], u["has_pin"]) for u in users}

    context = open_context(browser, TABLET)
    try:
        page = context.new_page()
        errors = PageErrors(page)
        page.goto(f"{runtime.url}/#/users")
        sign_in_by_touch(page, admin, admin_password)
        row = page.locator(f"[data-testid=user][data-name={operator}]")
        page.get_by_test_id(f"change-user-{operator}").tap()
        page.get_by_test_id("edit-role-programmer").tap()
        page.get_by_test_id("edit-pin").fill("2468")
        page.get_by_test_id("confirm-edit").fill("not my password")
        page.get_by_test_id("save-user").tap()
        expect(page.get_by_test_id("users-error")).to_be_visible()
        assert listed()[operator] == ("operator", False)  # refused: nothing changed
        page.get_by_test_id("confirm-edit").fill(admin_password)
        page.get_by_test_id("save-user").tap()
        expect(page.get_by_test_id("change-user")).to_have_count(0)
        expect(row).to_contain_text("Programmer")
        expect(row).to_contain_text("PIN")
        assert listed()[operator] == ("programmer", True)
        page.get_by_test_id(f"change-user-{operator}").tap()
        page.get_by_test_id("edit-no-pin").tap()
        page.get_by_test_id("confirm-edit").fill(admin_password)
        page.get_by_test_id("save-user").tap()
        expect(row).not_to_contain_text("PIN")
        assert listed()[operator] == ("programmer", False)
        assert errors.only_refusals(), "\n".join(errors.errors)
    finally:
        context.close()


def test_a_tablet_signed_out_elsewhere_says_why_on_its_sign_in_screen(
    runtime: Runtime, browser: Browser
) -> None:
    """Issue 32: a tablet dropped to the sign-in screen with no word of why. Its live sockets
    close when the session ends (within a second or two), and the screen says what ended it:
    here the same session signed out in another window, then a new role."""
    store = AuthStore(auth_path(runtime.data_dir))
    try:
        store.create_user("night-shift", "night shift password", Role.operator)
    finally:
        store.close()
    context = open_context(browser, TABLET)
    try:
        page = context.new_page()
        errors = PageErrors(page)
        page.goto(f"{runtime.url}/#/jog")
        sign_in_by_touch(page, "night-shift", "night shift password")
        expect(page.get_by_test_id("nav-jog")).to_be_visible()
        cookie = next(c["value"] for c in context.cookies() if c["name"] == "op_session")
        csrf = page.evaluate("fetch('/api/auth/me').then((r) => r.json()).then((me) => me.csrf)")
        elsewhere = {"Cookie": f"op_session={cookie}", "x-csrf-token": csrf}
        ended = runtime.api("POST", "/auth/logout", role=None, headers=elsewhere)
        assert ended.status_code == 204
        expect(page.get_by_test_id("sign-in-ended")).to_contain_text(
            "this session was signed out", timeout=10_000
        )
        sign_in_by_touch(page, "night-shift", "night shift password")
        expect(page.get_by_test_id("nav-jog")).to_be_visible()
        expect(page.get_by_test_id("sign-in-ended")).to_have_count(0)
        store = AuthStore(auth_path(runtime.data_dir))
        try:
            store.set_role("night-shift", Role.viewer)  # by an administrator, elsewhere
        finally:
            store.close()
        expect(page.get_by_test_id("sign-in-ended")).to_contain_text(
            "an administrator changed your role", timeout=10_000
        )
        # A socket opening again after the end is refused (a handshake refused reads 403).
        assert errors.only_refusals(), "\n".join(errors.errors)
    finally:
        context.close()


def test_plain_http_is_sent_on_to_https_and_a_jog_runs_over_the_jog_sockets_tls(
    runtime: Runtime, browser: Browser
) -> None:
    # The certificate is checked: without its authority nothing answers.
    with pytest.raises(httpx.ConnectError, match="CERTIFICATE_VERIFY_FAILED"):
        httpx.get(f"{runtime.url}/api/health", timeout=5)
    assert isinstance(runtime.verify, ssl.SSLContext)
    add_robot(runtime)
    name, password = runtime.user("operator")
    settings = yaml.safe_load((runtime.home / "config.yaml").read_text())
    plain = f"http://127.0.0.1:{settings['tls']['redirect_port']}"
    context = open_context(browser, TABLET)
    try:
        page = context.new_page()
        errors = PageErrors(page)
        sockets: list[str] = []
        page.on("websocket", lambda socket: sockets.append(socket.url))
        page.goto(f"{plain}/#/jog")
        assert page.url == f"{runtime.url}/#/jog"
        sign_in_by_touch(page, name, password)
        expect(page.get_by_test_id("nav-jog")).to_be_visible()
        session = next(c for c in context.cookies() if c["name"] == "op_session")
        assert session["secure"] and session["httpOnly"] and session["sameSite"] == "Strict"
        take_control_and_enable(page)
        before = robot_joints(runtime)
        finger = Finger(page)
        finger.down(page.locator("[data-testid=jog-row][data-axis='0'] [data-testid=jog-plus]"))
        try:
            wait_for(lambda: robot_joints(runtime)[0] - before[0] > 0.01, 10, what="J1 moving")
        finally:
            finger.up()
        wait_for(lambda: robot_at_rest(runtime), 5, what="stopped on release")
        port = runtime.api("GET", "/jog/settings").json()["socket_port"]
        assert f"wss://127.0.0.1:{port}/jog/ws" in [u.split("?")[0] for u in sockets]
        assert not [u for u in sockets if u.startswith("ws:")], sockets
        page.get_by_test_id("control").tap()
        page.get_by_test_id("nav-system").tap()
        shown = page.get_by_test_id("system-tls").get_by_test_id("tls-fingerprint")
        expect(shown).to_have_text(authority(runtime).fingerprint())
        # Before signing in, the page's first requests are refused (401): nothing else.
        assert errors.only_refusals(), "\n".join(errors.errors)
    finally:
        context.close()
    # The jog port speaks TLS only, as the UI's port does.
    with pytest.raises(httpx.HTTPError):
        httpx.get(f"http://127.0.0.1:{port}/jog/ws", timeout=5)
