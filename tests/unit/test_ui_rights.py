"""The UI disables what the role signed in may not do by the gateway's own table: the table is
served as the gateway enforces it (and JavaScript reads its patterns the same), and every
request the UI's code makes that changes something is declared by a control
(`makes(request(…))`, webui/frontend/src/rights.ts), so a new control cannot be forgotten.
Whether each control's disabled state then matches the table is tests/browser/
test_rights.py."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.setup import create_token
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.webui import policy
from openpendant.webui.server import build_app
from tests.support.ts_requests import CHANGING, Source, sources

SRC = Path(__file__).resolve().parents[2] / "webui" / "frontend" / "src"

# Requests no control makes, by file, method and path as written, each with why.
NO_CONTROL = {
    # Asked as the jog socket opens; the controls that jog declare WS /api/jog/ws.
    ("jog-socket.ts", "POST", "/api/auth/ticket"),
    # The sign-in screen's, before there is a role (anyone may).
    ("sign-in.ts", "POST", "/api/auth/setup"),
    ("sign-in.ts", "POST", "/api/auth/login"),
    ("sign-in.ts", "POST", "/api/auth/pin"),
    # The Python previewed as blocks change (no control; not asked for a role that may not).
    ("program/document.ts", "POST", "/api/programs/_generate"),
    # A plugin panel's own requests, passed on: its controls declare them (pendant.declare).
    ("plugins.ts", "method", "?"),
}


def below_api(path: str) -> str:
    path = path.split("?")[0]
    return path[4:] or "/" if path == "/api" or path.startswith("/api/") else path


def undeclared(found: list[Source]) -> list[str]:
    """Every changing request (and socket) of the sources no control declares."""
    declared = [d for s in found for d in s.declared()]
    missing = []
    for call in (c for s in found for c in s.calls()):
        if call.literal and call.method not in CHANGING:
            continue
        if (call.file, call.method, call.text()) in NO_CONTROL:
            continue
        if call.shape is None:
            missing.append(f"{call.file}: {call.method} {call.text()} (write its path readably)")
        elif not any(call.covers(d) for d in declared):
            missing.append(f"{call.file}: {call.method} {call.text()}")
    for socket in (p for s in found for p in s.socket_paths()):
        need = policy.need("WS", below_api(socket.sample()))
        if not (isinstance(need, Role) and need > Role.viewer):
            continue  # a viewer's socket reads
        if not any(
            d.method == "WS" and below_api(d.sample()) == below_api(socket.sample())
            for d in declared
        ):
            missing.append(f"{socket.file}: WS {socket.text()}")
    return missing


def test_every_request_that_changes_something_is_declared_by_a_control() -> None:
    found = sources(SRC)
    problems = undeclared(found)
    assert problems == [], "no control declares these (makes(request(…)) in rights.ts):\n" + (
        "\n".join(problems)
    )
    written = {(c.file, c.method, c.text()) for s in found for c in s.calls()}
    assert written >= NO_CONTROL, f"no longer made: {sorted(NO_CONTROL - written)}"


def test_the_scan_reads_calls_and_finds_a_forgotten_control() -> None:
    # The scan sees the calls it must: a template with a constant and a method in it too.
    calls = {(c.file, c.method, c.text()) for s in sources(SRC) for c in s.calls()}
    assert ("components/add-device-dialog.ts", "POST", "/api/devices") in calls
    assert ("panels/scene-panel.ts", "PUT", "/api/variables/frames.{}") in calls
    assert ("vision/intrinsic-tab.ts", "POST", "/api/vision/intrinsic/{}/capture") in calls
    code = """
      const base = `/api/things/${encodeURIComponent(name)}`;
      await api<Thing<Part>>("PUT", `${base}/parts`, { a: ")" }); // api("DELETE", "/x")
      await api("GET", "/api/things");
    """
    forgotten = Source("thing.ts", code)
    assert [c.text() for c in forgotten.calls()] == ["/api/things/{}/parts", "/api/things"]
    assert undeclared([forgotten]) == ["thing.ts: PUT /api/things/{}/parts"]
    other = Source("other.ts", 'html`<b ${makes(request("PUT", "/api/things/t1/parts"))}>`')
    assert undeclared([forgotten, other]) == []
    # A declaration of one request does not stand for a more general one.
    narrow = Source("narrow.ts", 'html`<b ${makes(request("PUT", `/api/x/frames.${n}`))}>`')
    general = Source("general.ts", 'api("PUT", `/api/x/${encodeURIComponent(n)}`)')
    assert undeclared([general, narrow]) == []
    assert undeclared([Source("f.ts", 'api("PUT", `/api/x/frames.${n}`)'), general]) != []
    # The generated client's calls: each {name} of the path as params.path gives it.
    typed = Source(
        "typed.ts",
        """const where = { params: { path: { name: n } } };
        await ok(client.PUT("/api/x/{name}", { params: { path: { name: `frames.${n}` } } }));
        await ok(client.DELETE("/api/x/{name}/y", where));
        await ok(client.POST("/api/x/{name}/call/{method}",
          { ...where, params: { path: { name: n, method: "write" } }, body }));""",
    )
    assert [c.text() for c in typed.calls()] == [
        "/api/x/frames.{}",
        "/api/x/{}/y",
        "/api/x/{}/call/write",
    ]
    assert undeclared([typed, narrow]) == [
        "typed.ts: DELETE /api/x/{}/y",
        "typed.ts: POST /api/x/{}/call/write",
    ]
    jogging = Source("j.ts", 'new WebSocket(socketUrl("/api/jog/ws"))')
    assert undeclared([jogging]) == ["j.ts: WS /api/jog/ws"]


def test_the_policy_route_serves_the_table_to_anyone_signed_in(tmp_path: Path) -> None:
    app = build_app(RuntimeSettings(sim=False, data_dir=tmp_path), {})
    viewer = create_token(tmp_path, "viewer", "tests")
    with TestClient(app, base_url="http://127.0.0.1:8080") as client:
        assert client.get("/api/auth/policy").status_code == 401
        served = client.get("/api/auth/policy", headers={"Authorization": f"Bearer {viewer}"})
    assert served.status_code == 200
    assert served.json() == {
        "rules": policy.served(),
        "roles": ["viewer", "operator", "programmer", "admin"],
        "otherwise": "admin",
    }
    assert policy.need("GET", "/auth/policy") == Role.viewer
    assert len(policy.served()) == len(policy.RULES)


def example(pattern: str) -> str:
    """A path a rule's pattern matches: each name an "x", the first of alternatives."""
    path = pattern.removeprefix("^").removesuffix("\\Z")
    path = path.replace("[^/]+", "x").replace(".*", "any/thing")
    path = re.sub(r"\(([^()|]*)\)\?", r"\1", path)
    path = re.sub(r"\(([^()|]*)(?:\|[^()]*)?\)", r"\1", path)
    return path.replace("\\", "")


JS_NEED = """
const { rules, otherwise, asked } = JSON.parse(require("fs").readFileSync(0, "utf8"));
const compiled = rules.map((r) => ({ ...r, pattern: new RegExp(r.pattern) }));
const needs = asked.map(([method, path]) => {
  const rule = compiled.find((r) => r.methods.includes(method) && r.pattern.test(path));
  return rule ? rule.need : otherwise;
});
process.stdout.write(JSON.stringify(needs));
"""


def test_javascript_reads_the_served_patterns_as_the_gateway_does() -> None:
    node = shutil.which("node")
    if node is None:
        pytest.fail("node is needed (make setup installs it)")
    paths = {example(r.pattern.pattern) for r in policy.RULES}
    assert all(
        any(r.pattern.match(p) for r in policy.RULES[:-1]) for p in paths if p != "/any/thing"
    )
    declared = {below_api(d.sample()) for s in sources(SRC) for d in s.declared()}
    # Near misses: a trailing slash or line feed, a deeper path, a name that is empty.
    tricky = {f"{p}/" for p in paths} | {f"{p}\n" for p in paths} | {f"{p}/y" for p in paths}
    tricky |= {"/devices//lease", "/auth/loginx", "/programs/_stop/x", "/", "/variables/a.b"}
    asked = [
        (method, path)
        for path in sorted(paths | declared | tricky)
        for method in ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "WS")
    ]
    table = {"rules": policy.served(), "otherwise": "admin", "asked": asked}
    run = subprocess.run(
        [node, "-e", JS_NEED], input=json.dumps(table), capture_output=True, text=True, check=True
    )
    theirs = json.loads(run.stdout)
    ours = [need.name if isinstance(need := policy.need(m, p), Role) else need for m, p in asked]
    differ = [(a, o, t) for a, o, t in zip(asked, ours, theirs, strict=True) if o != t]
    assert differ == []
    assert len(set(ours)) == 6  # every role, public and internal were asked about
