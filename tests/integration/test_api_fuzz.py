"""Schemathesis against every service's OpenAPI schema, through the gateway as an
administrator (the role that reaches the most code): generated requests, valid and invalid,
never make a service fail (no 5xx). Bodies no generator makes (NaN, deep nesting, numbers
with thousands of digits, control characters) are sent by hand and refused with a 4xx that
says what is wrong.

The seed is fixed, so a run is repeatable; a failure prints schemathesis's report with a
curl line that reproduces it."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from openpendant.runtime.bench.harness.processes import Runtime

# No real-time margins here: runs alongside the rest (tests/suite.py).
pytestmark = pytest.mark.concurrent

SERVICES = ("device_manager", "variable_storage", "jog", "motion", "program", "vision", "webui")
SCHEMATHESIS = Path(sys.executable).with_name("schemathesis")


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    proc = Runtime(tmp_path_factory.mktemp("fuzz"), extra=["--no-sim"])
    proc.wait_ready()
    yield proc
    proc.stop()


def schema_of(runtime: Runtime, service: str) -> dict[str, Any]:
    """A service's live schema; the gateway's without its proxy routes (the services' own
    schemas cover what they reach) and without /health (not below /api)."""
    if service == "webui":
        schema: dict[str, Any] = httpx.get(
            f"{runtime.url}/openapi.json", headers=runtime.auth()
        ).json()
        schema["paths"] = {
            path: ops
            for path, ops in schema["paths"].items()
            if path != "/health" and "{prefix}" not in path
        }
        return schema
    info = runtime.api("GET", "/health").json()["services"][service]
    schema = httpx.get(f"{info['url']}/openapi.json", headers=runtime.internal()).json()
    schema["paths"] = {p: ops for p, ops in schema["paths"].items() if p != "/health"}
    return schema


@pytest.mark.parametrize("service", SERVICES)
def test_generated_requests_never_make_a_service_fail(
    runtime: Runtime, service: str, tmp_path: Path
) -> None:
    schema = schema_of(runtime, service)
    operations = sum(len(ops) for ops in schema["paths"].values())
    assert operations >= 3
    (tmp_path / "schema.json").write_text(json.dumps(schema))
    base = runtime.url if service == "webui" else f"{runtime.url}/api"
    argv = [
        str(SCHEMATHESIS),
        "run",
        "schema.json",
        f"--url={base}",
        f"--header=Authorization: Bearer {runtime.token('admin')}",
        "--checks=not_a_server_error",
        "--phases=coverage,fuzzing",
        "--mode=all",
        "--max-examples=15",
        "--seed=7",
        "--workers=1",
        "--request-timeout=30",
    ]
    # Run in the test's own directory: schemathesis keeps its example database there.
    done = subprocess.run(
        argv, cwd=tmp_path, capture_output=True, text=True, timeout=600, check=False
    )
    report = done.stdout + done.stderr
    assert done.returncode == 0, report[-8000:]
    tested = re.search(r"Tested: (\d+)", report)
    assert tested is not None and int(tested.group(1)) == operations, report[-3000:]
    assert runtime.alive()


def test_bodies_no_generator_makes_are_refused_with_a_clear_reason(runtime: Runtime) -> None:
    deep = "[" * 50_000 + "]" * 50_000
    digits = "9" * 5000
    number = '{"type": "number", "value": 1}'
    plan = "/motion/robots/r/plan"
    cases: list[tuple[str, str, str, str]] = [
        # (method, path, raw JSON body, what the message must say)
        ("PUT", "/variables/probe", '{"type": "number", "value": NaN}', "NaN"),
        ("PUT", "/variables/probe", '{"type": "number", "value": 1e400}', "infinite"),
        ("PUT", "/variables/probe", deep, "nested too deeply"),
        ("PUT", "/variables/probe", f'{{"type": "number", "value": {digits}}}', "too many digits"),
        ("PUT", "/variables/pro%00be", number, "control characters"),
        ("PUT", "/variables/pro%E2%80%AEbe", number, "control characters"),
        ("POST", plan, '{"kind": "joint", "target": {"joints": [NaN]}}', "finite"),
        ("POST", plan, '{"kind": "linear", "target": {"waypoint": "../x"}}', "pattern"),
        ("POST", plan, deep, "nested too deeply"),
        ("POST", "/programs/p/rename", '{"to": "a\\u0000b"}', "name"),
        ("POST", "/programs/p/rename", '{"to": "a\\u202eb"}', "name"),
        ("POST", "/auth/login", f'{{"user": "a", "password": {digits}}}', "too many digits"),
        ("POST", "/auth/login", '{"user": "a\\u0000", "password": "b"}', "wrong user"),
        ("POST", "/devices", '{"url": "http://x", "local_name": "x\\u202ey"}', "local_name"),
    ]
    json_type = {"content-type": "application/json"}
    wrong = []
    assert runtime.api("PUT", "/programs/p", json={"python": "x = 1"}).status_code == 200
    for method, path, raw, says in cases:
        sent = runtime.api(method, path, content=raw, headers=json_type)
        message = sent.json()["error"]["message"] if sent.status_code >= 400 else ""
        if not (400 <= sent.status_code < 500 and message and says in message):
            wrong.append(f"{method} {path} {raw[:60]!r}: {sent.status_code} {sent.text[:300]}")
    assert not wrong, "\n".join(wrong)
    assert runtime.api("GET", "/variables/probe").status_code == 404
    assert [p["name"] for p in runtime.api("GET", "/programs").json()] == ["p"]
