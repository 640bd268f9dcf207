"""Signing in on a tablet by touch: the first start's set-up of the administrator, an
operator refused the administrator's page, hostile text shown as text, signing out, and a
tablet whose session ended elsewhere saying why on its sign-in screen."""

from __future__ import annotations

from pathlib import Path

from playwright.sync_api import Browser, Page, expect

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.setup import auth_path
from openpendant.runtime.auth.store import AuthStore
from openpendant.runtime.bench.harness.processes import Runtime, SimRobotProc, wait_for
from tests.browser.conftest import TABLET, PageErrors, open_context

HOSTILE = '<img src=x onerror="window.__pwned=1">'


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
        page.goto(runtime.url)
        expect(page.get_by_test_id("sign-in")).to_contain_text("Set up OpenPendant")
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
