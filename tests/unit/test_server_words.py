"""Server texts carry words (issue 32: in German the pre-run problems and program output
stayed English): a stable code and its params beside the English. Every code the runtime can
send is in the registry (read from the code itself), each has its text in every catalogue of
the UI with the same placeholders, and the refusals, problems and run errors a user meets
carry them."""

from __future__ import annotations

import ast
import asyncio
import json
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from openpendant.blockly_blocks.generate import generate
from openpendant.blockly_blocks.generator import INPUT_WORDS
from openpendant.blockly_blocks.workspace import WorkspaceError
from openpendant.runtime.auth.audit import AuditLog
from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.store import AuthStore
from openpendant.runtime.device_manager.leases import LeaseBook
from openpendant.runtime.kit.errors import Conflict, OpenPendantError
from openpendant.runtime.kit.words import CODES, Words, words, words_of
from openpendant.runtime.program.compiler import prepare_save, workspace_error
from openpendant.runtime.program.reserved_names import refuse_reserved
from openpendant.sandbox.supervisor import CallRefused, ProgramRun, RunLimits
from openpendant.webui.access import AccessGuard

ROOT = Path(__file__).resolve().parents[2]
SOURCES = ("runtime", "webui", "blockly_blocks", "sandbox", "plugins", "device_drivers")
CATALOGUES = ROOT / "webui" / "frontend" / "src" / "i18n"
# A "key": "text" entry of a catalogue, the text on the same line or the next.
ENTRY = re.compile(r'^\s*"(server\.[^"]+)":\s*\n?\s*"((?:[^"\\]|\\.)*)"', re.M)
PLACEHOLDER = re.compile(r"\{(\w+)\}")


def python_files() -> Iterator[Path]:
    for top in SOURCES:
        yield from sorted((ROOT / top).rglob("*.py"))


def uses_words(tree: ast.Module) -> bool:
    return any(
        isinstance(node, ast.ImportFrom)
        and node.module == "openpendant.runtime.kit.words"
        and any(alias.name == "words" for alias in node.names)
        for node in ast.walk(tree)
    )


def sent_codes() -> dict[str, list[tuple[str, frozenset[str]]]]:
    """Every words(...) call in the source: its code (a literal, either of a conditional's
    literals, or a family's under an f-string's prefix) with the params it names, by where
    it is."""
    found: dict[str, list[tuple[str, frozenset[str]]]] = {}
    for path in python_files():
        tree = ast.parse(path.read_text(), str(path))
        if not uses_words(tree) and path != ROOT / "runtime" / "kit" / "words.py":
            continue  # a words() of its own (the blocks' words)
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "words"):
                continue
            where = f"{path.relative_to(ROOT)}:{node.lineno}"
            first = node.args[0] if node.args else None
            params = frozenset(k.arg for k in node.keywords if k.arg is not None)
            if isinstance(first, ast.Constant) and isinstance(first.value, str):
                codes = [first.value]
            elif isinstance(first, ast.IfExp) and all(
                isinstance(b, ast.Constant) for b in (first.body, first.orelse)
            ):
                codes = [first.body.value, first.orelse.value]  # type: ignore[attr-defined]
            elif isinstance(first, ast.JoinedStr) and isinstance(first.values[0], ast.Constant):
                # One of a family (a role's, an input's, a session end's): every code
                # registered under its prefix.
                prefix = str(first.values[0].value)
                codes = [code for code in CODES if code.startswith(prefix)]
                assert codes, f"{where}: no code is registered under {prefix!r}"
                params = frozenset()
            else:
                raise AssertionError(f"{where}: a code must be written out, not computed")
            for code in codes:
                found.setdefault(code, []).append((where, params))
    return found


def catalogue(language: str) -> dict[str, str]:
    text = (CATALOGUES / f"{language}.ts").read_text()
    if language != "en":  # the UI's strings only, not the blocks' words after them
        text = text.split("export const deBlocks")[0]
    return {key: json.loads(f'"{value}"') for key, value in ENTRY.findall(text)}


def test_every_code_the_runtime_sends_is_registered_with_the_params_it_names() -> None:
    sent = sent_codes()
    unknown = {code: places for code, places in sent.items() if code not in CODES}
    assert not unknown, unknown
    for code, places in sent.items():
        for where, params in places:
            if params:  # a family's members take none; the others name theirs
                assert params == set(CODES[code]), (where, code, sorted(params))
    # The families' members that are made: every role's, every input's.
    assert {f"role.{role.name}" for role in Role} <= set(CODES)
    assert {f"program.input.{word}" for word in INPUT_WORDS.values()} <= set(CODES)
    # And nothing registered that nothing sends.
    assert set(CODES) == set(sent)


@pytest.mark.parametrize("language", ["en", "de"])
def test_every_code_has_its_words_in_every_catalogue(language: str) -> None:
    strings = catalogue(language)
    missing = sorted(code for code in CODES if f"server.{code}" not in strings)
    assert not missing, missing
    assert set(strings) == {f"server.{code}" for code in CODES}  # none left over
    for code, params in CODES.items():
        shown = set(PLACEHOLDER.findall(strings[f"server.{code}"]))
        assert shown == set(params), (language, code)


def test_the_catalogues_are_read_as_written() -> None:
    """The parse above sees entries, not nothing: a known one, exactly."""
    assert catalogue("de")["server.program.input_empty"] == "Block „{block}“: {input} fehlt"
    assert len(catalogue("en")) > 50


def test_words_cross_services_in_the_error_body_and_nothing_else_does() -> None:
    said = words("lease.held", device="ur5", holder="Cell 2")
    error = Conflict("ur5 is controlled by 'Cell 2'", code="lease_held", words=said)
    body = error.body()
    assert body["error"]["words"] == {"code": "lease.held", "params": said.params}
    back = OpenPendantError.from_body(409, json.loads(json.dumps(body)))
    assert back.words == said and back.code == "lease_held"
    nested = words("access.role", role=words("role.operator"), need=words("role.admin"))
    assert words_of(json.loads(json.dumps(nested.body()))) == nested
    for broken in (
        {"code": "not a code"},
        {"code": "a.b", "params": {"x": [1]}},
        {"code": "a.b", "params": {"x": float("nan")}},
        {"code": "a.b", "params": {"bad name": 1}},
        "lease.held",
    ):
        assert words_of(broken) is None, broken


@pytest.fixture
def gateway(tmp_path: Path) -> Iterator[tuple[TestClient, AuthStore]]:
    store = AuthStore(tmp_path / "auth.sqlite")
    audit = AuditLog(tmp_path / "audit.sqlite")
    app = FastAPI()

    @app.put("/api/programs/{name}")
    async def save(name: str) -> dict[str, str]:
        return {"name": name}

    app.add_middleware(AccessGuard, store=store, audit=audit)
    yield TestClient(app, base_url="http://127.0.0.1:8080"), store
    store.close()


def test_the_gateways_refusal_names_both_roles_in_words(
    gateway: tuple[TestClient, AuthStore],
) -> None:
    client, store = gateway
    store.create_user("olga", "correct horse battery", Role.operator)
    token = store.create_token("olga", Role.operator)
    refused = client.put("/api/programs/cycle", headers={"authorization": f"Bearer {token}"})
    assert refused.status_code == 403
    error = refused.json()["error"]
    assert error["message"] == "an operator may not do this (a programmer may)"
    assert error["words"] == {
        "code": "access.role",
        "params": {
            "role": {"code": "role.operator", "params": {}},
            "need": {"code": "role.programmer", "params": {}},
        },
    }
    anonymous = client.put("/api/programs/cycle").json()["error"]
    assert anonymous["words"] == {"code": "access.sign_in", "params": {}}


def block(kind: str, ident: str, y: int, **inputs: Any) -> dict[str, Any]:
    found: dict[str, Any] = {"type": kind, "id": ident, "x": 0, "y": y}
    if inputs:
        found["inputs"] = {name: {"block": child} for name, child in inputs.items()}
    return found


def test_every_pre_run_problem_is_in_words() -> None:
    """The two kinds the check reports: an empty input (named in words of its own) and a
    block lying apart; and a fault of the blocks that gives no program at all."""
    number = {"type": "math_number", "id": "n1", "fields": {"NUM": 3}}
    workspace = {
        "blocks": {
            "blocks": [
                block("controls_repeat_ext", "r1", 0),
                block("controls_if", "i1", 100),
                block("text_print", "p1", 200, TEXT=number),
                block("lists_reverse", "s1", 300),
                {**block("lists_split", "t1", 400), "fields": {"MODE": "SPLIT"}},
            ]
        }
    }
    body = json.dumps({"workspace": workspace}).encode()
    problems = [
        (p.block, p.words.model_dump() if p.words else None) for p in prepare_save(body).problems
    ]
    assert ("r1", _empty("repeat ext", "program.input.times")) in problems
    assert ("i1", _empty("if", "program.input.condition")) in problems
    assert ("p1", {"code": "program.loose", "params": {"block": "print"}}) in problems
    assert ("s1", _empty("reverse", "program.input.list")) in problems
    named = {"code": "program.input.named", "params": {"name": "input"}}
    assert ("t1", {**_empty("split", ""), "params": {"block": "split", "input": named}}) in problems
    assert all(w is not None and w["code"] in CODES for _, w in problems)

    unknown = {"blocks": {"blocks": [block("no_such_block", "x1", 0)]}}
    with pytest.raises(WorkspaceError) as refused:
        generate(unknown)
    said = workspace_error(refused.value).words
    assert said == words("program.unknown_block", type="no_such_block")
    bare = workspace_error(WorkspaceError('"blocks" must be an object'))
    assert bare.words == words("program.unreadable", reason='"blocks" must be an object')


def _empty(kind: str, label: str) -> dict[str, Any]:
    return {
        "code": "program.input_empty",
        "params": {"block": kind, "input": {"code": label, "params": {}}},
    }


def test_the_refusals_a_user_meets_most_are_in_words() -> None:
    leases = LeaseBook()
    leases.acquire("ur5", "Cell 2")
    with pytest.raises(OpenPendantError) as held:
        leases.acquire("ur5", "me")
    assert held.value.words == words("lease.held", device="ur5", holder="Cell 2")
    with pytest.raises(OpenPendantError) as required:
        LeaseBook().check("ur5", None)
    assert required.value.words == words("lease.required", device="ur5")
    with pytest.raises(CallRefused) as reserved:
        refuse_reserved("frames.robot")
    assert reserved.value.words == words("storage.reserved", name="frames.robot", prefix="frames.")


class RefusingHost:
    """Answers a program's moves as the runtime does when the robot is not enabled."""

    async def call(self, fn: str, args: dict[str, Any]) -> Any:
        raise CallRefused("the robot is not enabled", "not_enabled", words("robot.not_enabled"))

    async def halt(self) -> None:
        pass


def run(source: str) -> ProgramRun:
    async def go() -> ProgramRun:
        program = ProgramRun(source, RefusingHost(), limits=RunLimits(wall_seconds=30))
        await program.start()
        await program.wait(40)
        await program.close()
        return program

    return asyncio.run(go())


def test_a_runs_errors_keep_their_words_through_the_worker() -> None:
    refused = run("move_joint(waypoint('pick'))\n")
    assert refused.error is not None and refused.error.code == "not_enabled"
    assert refused.error.words == words("robot.not_enabled")
    line = refused.output[-1]
    assert line.stream == "error" and line.words == words(
        "run.at_line", message=words("robot.not_enabled"), line=1
    )
    failed = run("x = 1\ny = x / 0\n")
    assert failed.error is not None
    assert failed.error.words == words("run.exception", error="ZeroDivisionError: division by zero")


def test_words_are_plain_data() -> None:
    """What the API shows: a code and params, nested words as their bodies."""
    said = words("run.at_line", message=words("run.stopped"), line=3)
    assert isinstance(said, Words)
    assert said.body() == {
        "code": "run.at_line",
        "params": {"message": {"code": "run.stopped", "params": {}}, "line": 3},
    }
