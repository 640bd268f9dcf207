"""The API's one document (webui/openapi.py), from which the UI's client is generated: every
service's routes below /api, each answer typed, the fields the runtime always sends required,
two models of one name refused; and every call of the UI goes through the generated client
(`npm run build` type-checks each against it)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.services import load_factory, services
from openpendant.webui import openapi
from openpendant.webui.openapi import FORWARDING, SchemaConflict, gateway_schema

pytestmark = pytest.mark.concurrent

UI = Path(__file__).resolve().parents[2] / "webui" / "frontend" / "src"
# Answers that are not a model: files, a kind's state or method result (its plugin's to say),
# a service's own health (what else each says of itself).
UNTYPED = {
    ("get", "/health"),
    ("get", "/api/auth/audit/export"),
    ("post", "/api/devices/{local_name}/call/{method}"),
    ("get", "/api/devices/{local_name}/state"),
    ("get", "/api/robot-files/{package}/{path}"),
    ("get", "/api/variables/_export"),
    ("get", "/api/vision/cameras/{camera}/calibration.yaml"),
    ("get", "/plugins/{plugin}/{path}"),
}


@pytest.fixture(scope="module")
def document() -> dict[str, Any]:
    return gateway_schema()


def test_every_services_route_is_in_it_below_api(document: dict[str, Any], tmp_path: Path) -> None:
    urls = {spec.name: "http://127.0.0.1:9" for spec in services()}
    for spec in services():
        app = load_factory(spec)(RuntimeSettings(data_dir=tmp_path), urls)
        for path, item in app.openapi()["paths"].items():
            assert set(item) <= set(document["paths"][f"/api{path}"]), (spec.name, path)
    assert not set(FORWARDING) & set(document["paths"])
    assert "/api/auth/login" in document["paths"]  # the gateway's own
    schemas = document["components"]["schemas"]
    assert {"RobotState", "InputState"} <= set(schemas)  # streamed: in no route


def typed(schema: dict[str, Any]) -> bool:
    if "$ref" in schema:
        return True
    if schema.get("type") == "array":
        return typed(schema.get("items", {}))
    if "anyOf" in schema:
        return all(typed(s) or s.get("type") == "null" for s in schema["anyOf"])
    if schema.get("type") == "object":
        return "properties" in schema or isinstance(schema.get("additionalProperties"), dict)
    return schema.get("type") in ("string", "integer", "number", "boolean")


def test_every_answer_is_a_model(document: dict[str, Any]) -> None:
    loose = []
    for path, item in document["paths"].items():
        for method, operation in item.items():
            for code, response in operation.get("responses", {}).items():
                content = response.get("content", {}).get("application/json")
                if code.startswith("2") and content and not typed(content.get("schema", {})):
                    loose.append((method, path))
    assert set(loose) <= UNTYPED, sorted(set(loose) - UNTYPED)


def test_what_the_runtime_sends_has_every_field_and_what_it_is_sent_may_leave_some_out(
    document: dict[str, Any],
) -> None:
    schemas = document["components"]["schemas"]
    assert "trajectory" in schemas["RobotState"]["required"]  # None has a default, still sent
    assert "connected_since" in schemas["AddedDevice"]["required"]
    assert "leases" not in schemas["RunRequest"].get("required", [])  # only ever sent to it
    body = document["paths"]["/api/programs/{name}"]["put"]["requestBody"]
    assert "workspace" in body["content"]["application/json"]["schema"]["properties"]


def test_two_models_of_one_name_are_refused() -> None:
    schemas: dict[str, Any] = {}
    openapi._add(schemas, "Pose", {"type": "object", "title": "Pose"}, "motion")
    openapi._add(schemas, "Pose", {"type": "object", "title": "A pose"}, "jog")  # words only
    with pytest.raises(SchemaConflict, match="'Pose'"):
        openapi._add(schemas, "Pose", {"type": "array"}, "vision")
    # A field called "description" is a field, not a model's description.
    info = {"type": "object", "properties": {"description": {"type": "string"}}}
    openapi._add(schemas, "Info", info, "motion")
    with pytest.raises(SchemaConflict, match="'Info'"):
        openapi._add(schemas, "Info", {"type": "object", "properties": {}}, "jog")


def test_the_ui_calls_the_api_only_through_its_generated_client() -> None:
    raw = []
    for source in UI.rglob("*.ts"):
        if "generated" in source.parts:
            continue
        text = re.sub(r"//[^\n]*", "", source.read_text())
        name = source.relative_to(UI).as_posix()
        if re.search(r"(?<![.\w])fetch\(", text) and name != "api.ts":
            raw.append(f"{name}: fetch")
        if re.search(r"\buntyped\(", text) and name not in ("api.ts", "plugins.ts"):
            raw.append(f"{name}: untyped")  # for a plugin's routes only
    assert raw == []
    assert (UI / "types.ts").read_text().count("interface") == 0  # aliases of the document's
