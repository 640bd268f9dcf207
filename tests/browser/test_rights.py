"""What a role may not do is disabled before the tap, by the gateway's own table (issue 32):
for a viewer, an operator and a programmer on a touch tablet, every control that declares a
request (`data-request`) on every panel, and in the dialogs and tabs that hold them, is
aria-disabled exactly when webui/policy.py refuses that role the request; a tap on one says
why where the finger is, in the UI's language, and makes no request."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest
from playwright.sync_api import Browser, BrowserContext, Locator, Page, expect

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.bench.harness.processes import Runtime, child_env, wait_for
from openpendant.runtime.kit.settings import default_devices
from openpendant.webui import policy
from tests.browser.conftest import (
    BROWSER_LINK_TIMEOUT,
    TABLET,
    PageErrors,
    add_robot,
    open_context,
    sign_in,
)
from tests.support.programs import ABOVE_PICK, pick_and_place, teach
from tests.support.vision import CAMERA_SPEC, Cam

# A slow camera: its controls are what is looked at here, not its pictures.
CAMERA = CAMERA_SPEC.model_copy(update={"options": {**CAMERA_SPEC.options, "fps": 5}})
ROBOT, IO, GRIPPER = default_devices()
BOX = {
    "shape": "box",
    "size": [0.1, 0.1, 0.1],
    "pose": {"position": [0.6, 0.3, 0.05], "orientation": [0, 0, 0, 1]},
    "keep_out": False,
    "color": "#8a94a6",
    "attached_to": None,
}

# Every shadow root walked: each control that declares a request, and its state.
DECLARED = """() => {
  const found = [];
  const walk = (root) => {
    for (const el of root.querySelectorAll("*")) {
      if (el.hasAttribute("data-request")) {
        found.push({
          request: el.getAttribute("data-request"),
          refused: el.getAttribute("aria-disabled") === "true",
          control: el.getAttribute("data-testid") || el.tagName.toLowerCase(),
        });
      }
      if (el.shadowRoot) walk(el.shadowRoot);
    }
  };
  walk(document);
  return found;
}"""

# A component found through the shadow roots, its state set: the dialogs a role may not open
# by a tap (their opener is disabled) are opened so, to look at what they hold.
SET_STATE = """([selector, state]) => {
  const find = (root) => {
    const here = root.querySelector(selector);
    if (here) return here;
    for (const el of root.querySelectorAll("*")) {
      const inner = el.shadowRoot && find(el.shadowRoot);
      if (inner) return inner;
    }
    return null;
  };
  Object.assign(find(document), state);
}"""


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    """The robot, its I/O block and a camera added; the gripper detected but not added (a
    device to add)."""
    home = tmp_path_factory.mktemp("rights")
    devices = [d.model_dump() for d in (ROBOT, IO, GRIPPER, CAMERA)]
    env = child_env(
        home,
        OPENPENDANT_DEVICES=json.dumps(devices),
        OPENPENDANT_LINK__STALE_AFTER=str(BROWSER_LINK_TIMEOUT),
        OPENPENDANT_LINK__DRIVER_TIMEOUT=str(BROWSER_LINK_TIMEOUT),
    )
    proc = Runtime(home, env=env)
    proc.wait_ready()
    add_robot(proc)
    io = proc.own_device(IO)["uuid"]
    assert proc.api("POST", "/devices", json={"uuid": io, "local_name": "io"}).is_success
    wait_for(lambda: proc.api("GET", "/devices/io").json()["status"] == "connected", 30)
    Cam(proc, CAMERA)
    proc.own_device(GRIPPER)
    teach(proc, {"wp_1": ABOVE_PICK})
    box = {"type": "scene_object", "value": BOX}
    assert proc.api("PUT", "/variables/box_1", json=box).is_success
    assert proc.api("PUT", "/programs/cycle", json={"workspace": pick_and_place()[0]}).is_success
    yield proc
    proc.stop()
    assert proc.service_errors() == []


def signed_in(browser: Browser, runtime: Runtime, role: str) -> tuple[BrowserContext, Page]:
    context = open_context(browser, TABLET)
    sign_in(context, runtime, role)
    page = context.new_page()
    return context, page


def show(page: Page, runtime: Runtime, panel: str, ready: str) -> None:
    page.goto(f"{runtime.url}/#/{panel}")
    expect(page.get_by_test_id(ready).first).to_be_attached(timeout=20_000)


def opened(page: Page, selector: str, state: dict[str, Any], ready: str) -> None:
    page.evaluate(SET_STATE, [selector, state])
    expect(page.get_by_test_id(ready).first).to_be_attached(timeout=10_000)


def every_panel(page: Page, runtime: Runtime) -> list[dict[str, Any]]:
    """The declared controls of every panel and of the dialogs and tabs they open."""
    seen: list[dict[str, Any]] = []

    def look() -> None:
        seen.extend(page.evaluate(DECLARED))

    show(page, runtime, "devices", "add-by-address")
    expect(page.get_by_test_id("add-device").first).to_be_attached(timeout=15_000)
    look()
    panel = "op-devices-panel"
    device = {"local_name": "robot"}
    opened(
        page, panel, {"dialog": {"kind": "add", "device": None, "url": "http://x:1"}}, "confirm-add"
    )
    look()
    opened(page, panel, {"dialog": {"kind": "remove", "device": device}}, "confirm-remove")
    look()
    repoint = {"kind": "repoint", "device": device, "url": "http://x:1"}
    opened(page, panel, {"dialog": repoint}, "confirm-repoint")
    look()

    show(page, runtime, "jog", "jog-plus")
    expect(page.get_by_test_id("move-to").first).to_be_attached()
    look()
    panel = "op-jog-panel"
    teach_dialog = {"kind": "teach", "type": "joint", "frame": "base", "name": "wp_2",
                    "error": "", "overwrite": False}  # fmt: skip
    rename = {"kind": "rename", "from": "wp_1", "name": "wp_1", "tags": [], "error": ""}
    for dialog, ready in ((teach_dialog, "name-confirm"), (rename, "name-confirm")):
        opened(page, panel, {"dialog": dialog}, ready)
        look()
    opened(page, panel, {"dialog": {"kind": "delete", "name": "wp_1"}}, "confirm-delete")
    look()
    page.evaluate(SET_STATE, [panel, {"dialog": None}])

    show(page, runtime, "scene", "save-mount")
    page.locator("[data-testid=scene-object][data-name=box_1]").tap()
    expect(page.get_by_test_id("apply")).to_be_attached()
    expect(page.get_by_test_id("save-tool")).to_be_attached(timeout=15_000)
    look()

    show(page, runtime, "io", "io-control-io")
    look()

    show(page, runtime, "program", "run")
    expect(page.get_by_test_id("program-select")).to_have_value("cycle", timeout=20_000)
    look()
    for kind in ("new", "rename", "duplicate", "delete"):
        ready = "delete-confirm" if kind == "delete" else "name-confirm"
        opened(page, "op-program-panel", {"dialog": kind}, ready)
        look()
    page.evaluate(SET_STATE, ["op-program-panel", {"dialog": None}])

    show(page, runtime, "vision", "intrinsic-start")
    expect(page.get_by_test_id("placement-run")).to_be_attached()
    opened(page, "op-detect-tab", {"adding": True}, "detector-save")
    look()

    show(page, runtime, "system", "sign-out")
    look()
    return seen


def allowed(role: Role, method: str, path: str) -> bool:
    need = policy.need(method, path)
    return need == policy.PUBLIC or (isinstance(need, Role) and role >= need)


@pytest.mark.parametrize("role", ["viewer", "operator", "programmer"])
def test_every_control_is_disabled_exactly_where_the_table_refuses(
    runtime: Runtime, browser: Browser, role: str
) -> None:
    context, page = signed_in(browser, runtime, role)
    errors = PageErrors(page)
    try:
        seen = every_panel(page, runtime)
        controls = {c["control"] for c in seen}
        # The controls of issue 32's complaint, and one of each kind, were looked at.
        for control in ("add-device", "add-by-address", "confirm-add", "save-mount", "jog-plus",
                        "teach-joint", "move-to", "name-confirm", "control", "save", "run",
                        "delete-confirm", "apply", "io-control-io", "intrinsic-start",
                        "detector-save", "vision-import-label", "safety-stop", "speed",
                        "sign-out"):  # fmt: skip
            assert control in controls, control
        wrong = []
        for c in seen:
            requests = [r.split(" ", 1) for r in c["request"].split(", ")]
            for method, path in requests:
                # A real request of the table, with every name in its path filled in.
                assert policy.named(method, path) and "//" not in path, c
            expected = not all(allowed(Role[role], m, p) for m, p in requests)
            if c["refused"] != expected:
                wrong.append(f"{c['control']} ({c['request']}): refused={c['refused']}")
        assert wrong == [], f"{role}: " + "; ".join(wrong)
        assert errors.errors == []
    finally:
        context.close()


def reason_at(page: Page, control: Locator) -> str:
    """Taps a disabled control: the reason shows where the finger touched."""
    box = control.bounding_box()
    assert box is not None
    control.tap(force=True)  # Playwright would wait for an aria-disabled one to be enabled
    bubble = page.get_by_test_id("refusal-reason")
    expect(bubble).to_be_visible()
    shown = bubble.bounding_box()
    assert shown is not None
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    assert shown["x"] - 1 <= x <= shown["x"] + shown["width"] + 1
    assert -120 < y - (shown["y"] + shown["height"]) < 60 or 0 < shown["y"] - y < 60
    return bubble.inner_text()


def test_an_operator_sees_add_device_and_save_mounting_disabled_with_the_reason(
    runtime: Runtime, browser: Browser
) -> None:
    context, page = signed_in(browser, runtime, "operator")
    errors = PageErrors(page)
    try:
        show(page, runtime, "devices", "add-device")
        add = page.get_by_test_id("add-device").first
        expect(add).to_have_attribute("aria-disabled", "true")
        said = reason_at(page, add)
        assert "needs an administrator" in said and "signed in as an operator" in said
        assert "Add" in said
        expect(page.get_by_test_id("add-dialog")).to_have_count(0)  # no form to fill in
        # Typing an address and pressing Enter is refused the same, at the button.
        address = page.get_by_role("textbox", name="Device address")
        address.tap()
        expect(page.get_by_test_id("refusal-reason")).to_have_count(0)  # a touch took it away
        address.fill("http://127.0.0.1:9")
        address.press("Enter")
        bubble = page.get_by_test_id("refusal-reason")
        expect(bubble).to_contain_text("“Add…” needs an administrator")
        button, shown = page.get_by_test_id("add-by-address").bounding_box(), bubble.bounding_box()
        assert button is not None and shown is not None
        assert shown["x"] <= button["x"] + button["width"] / 2 <= shown["x"] + shown["width"]
        expect(page.get_by_test_id("add-dialog")).to_have_count(0)

        show(page, runtime, "scene", "save-mount")
        before = runtime.api("GET", "/variables/frames.robot")
        save = page.get_by_test_id("save-mount")
        expect(save).to_have_attribute("aria-disabled", "true")
        expect(save).to_have_css("opacity", "0.45")
        said = reason_at(page, save)
        assert "needs a programmer" in said and "an operator" in said
        assert runtime.api("GET", "/variables/frames.robot").text == before.text
        # In German too.
        page.evaluate("localStorage.setItem('op.language', 'de')")
        page.reload()
        expect(page.get_by_test_id("save-mount")).to_be_attached(timeout=20_000)
        said = reason_at(page, page.get_by_test_id("save-mount"))
        assert "braucht einen Programmierer" in said and "als Bediener angemeldet" in said
        assert errors.errors == []
    finally:
        context.close()


def test_a_viewers_hold_button_says_why_and_moves_nothing(
    runtime: Runtime, browser: Browser
) -> None:
    context, page = signed_in(browser, runtime, "viewer")
    errors = PageErrors(page)
    try:
        show(page, runtime, "jog", "jog-plus")
        before = runtime.api("GET", "/devices/robot/state").json()["joint_position"]
        hold = page.get_by_test_id("jog-plus").first
        expect(hold).to_have_attribute("aria-disabled", "true")
        said = reason_at(page, hold)
        assert "needs an operator" in said and "signed in as a viewer" in said
        after = runtime.api("GET", "/devices/robot/state").json()["joint_position"]
        assert after == pytest.approx(before, abs=1e-6)
        # STOP is every signed-in user's, the viewer's too.
        expect(page.get_by_test_id("safety-stop")).not_to_have_attribute("aria-disabled", "true")
        assert errors.errors == []
    finally:
        context.close()
