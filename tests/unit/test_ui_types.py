"""The UI's TypeScript types of the API (webui/frontend/src/types.ts) against the runtime's
OpenAPI schemas: every interface named like a schema component has exactly its fields, each
of the same type (numbers, text, true/false, lists, literal unions, nested models, null), so
the front end and the back end cannot drift apart unnoticed."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from openpendant.plugins.api import resolve
from openpendant.plugins.registry import registry
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.services import load_factory, services

TYPES = Path(__file__).resolve().parents[2] / "webui" / "frontend" / "src" / "types.ts"
MUST_CHECK = {"RobotState", "AddedDevice", "DetectedDevice", "DeviceDetails", "InputState"}
INTERFACE = re.compile(r"export interface (\w+)(?: extends (\w+))? \{(.*?)\n\}", re.S)
ALIAS = re.compile(r"export type (\w+) =(.*?);", re.S)
FIELD = re.compile(r"^\s*(\w+)(\??): (.+?);", re.M)


def components() -> dict[str, Any]:
    """Every schema component of every service's OpenAPI, and of every kind's state."""
    found: dict[str, Any] = {}
    urls = {spec.name: "http://127.0.0.1:9" for spec in services()}
    for spec in services():
        app = load_factory(spec)(RuntimeSettings(), urls)
        found.update(app.openapi().get("components", {}).get("schemas", {}))
    for kind in registry().kinds.values():
        model = resolve(kind.state)
        schema = model.model_json_schema(ref_template="#/components/schemas/{model}")
        found.update(schema.pop("$defs", {}))
        found[model.__name__] = schema
    return found


def typescript() -> tuple[dict[str, dict[str, tuple[str, bool]]], dict[str, str]]:
    """Interfaces (name -> field -> (type, optional)) and type aliases of types.ts."""
    text = re.sub(r"//[^\n]*|/\*.*?\*/", "", TYPES.read_text(), flags=re.S)
    aliases = {name: " ".join(body.split()) for name, body in ALIAS.findall(text)}
    interfaces: dict[str, dict[str, tuple[str, bool]]] = {}
    for name, parent, body in INTERFACE.findall(text):
        while re.search(r"\{[^{}]*\}", body):  # an inline object type is an object
            body = re.sub(r"\{[^{}]*\}", "object", body)
        fields = dict(interfaces.get(parent, {})) if parent else {}
        for field, optional, kind in FIELD.findall(body):
            fields[field] = (" ".join(kind.split()), optional == "?")
        interfaces[name] = fields
    return interfaces, aliases


def ts_shape(kind: str, aliases: dict[str, str]) -> Any:
    """A TypeScript type as a comparable shape."""
    kind = kind.strip()
    parts = [p.strip() for p in _split_union(kind) if p.strip()]
    if len(parts) == 1:
        kind = parts[0]
    else:
        literals = [p[1:-1] for p in parts if p.startswith('"')]
        others = frozenset(ts_shape(p, aliases) for p in parts if not p.startswith('"'))
        return ("union", frozenset(literals), others)
    if kind in aliases:
        return ts_shape(aliases[kind], aliases)
    if kind.startswith('"'):
        return ("union", frozenset([kind[1:-1]]), frozenset())
    if kind.endswith("[]"):
        return ("list", ts_shape(kind[:-2], aliases))
    if kind.startswith("[") and kind.endswith("]"):  # a tuple: a list of fixed length
        (item,) = {p.strip() for p in kind[1:-1].split(",")}
        return ("list", ts_shape(item, aliases))
    if kind.startswith("Record<string,"):
        return ("map", ts_shape(kind[len("Record<string,") : -1], aliases))
    if kind == "object":
        return ("object",)
    simple = {"number": ("number",), "string": ("string",), "boolean": ("boolean",)}
    return {**simple, "null": ("null",)}.get(kind, ("ref", kind))


def _split_union(kind: str) -> list[str]:
    parts, depth, current = [], 0, ""
    for char in kind:
        depth += (char in "<[{(" and 1) or ((char in ">]})" and -1) or 0)
        if char == "|" and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += char
    return [*parts, current]


def schema_shape(schema: dict[str, Any], all_schemas: dict[str, Any]) -> Any:
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[1]
        target = all_schemas.get(name, {})
        if "enum" in target:
            return ("union", frozenset(target["enum"]), frozenset())
        return ("ref", name)
    if "anyOf" in schema:
        shapes = [schema_shape(s, all_schemas) for s in schema["anyOf"]]
        literals = frozenset(v for s in shapes if s[0] == "union" for v in s[1])
        return ("union", literals, frozenset(s for s in shapes if s[0] != "union"))
    if "enum" in schema or "const" in schema:
        return ("union", frozenset(schema.get("enum", [schema.get("const")])), frozenset())
    kind = schema.get("type")
    if kind == "array":
        return ("list", schema_shape(schema.get("items", {}), all_schemas))
    if kind == "object":
        extra = schema.get("additionalProperties")
        if isinstance(extra, dict):
            return ("map", schema_shape(extra, all_schemas))
        return ("object",)
    if kind in ("integer", "number"):
        return ("number",)
    if kind in ("string", "boolean", "null"):
        return (kind,)
    return ("object",)  # any JSON value


def normal(shape: Any) -> Any:
    """A union of one shape and no literals is that shape."""
    if shape[0] == "union" and not shape[1] and len(shape[2]) == 1:
        return normal(next(iter(shape[2])))
    return shape


@pytest.fixture(scope="module")
def schemas() -> dict[str, Any]:
    return components()


def test_the_ui_types_match_the_runtimes_schemas(schemas: dict[str, Any]) -> None:
    interfaces, aliases = typescript()
    checked = sorted(set(interfaces) & set(schemas))
    assert set(checked) >= MUST_CHECK, sorted(MUST_CHECK - set(checked))
    problems = []
    for name in checked:
        fields = interfaces[name]
        properties = schemas[name].get("properties", {})
        for missing in sorted(set(properties) - set(fields)):
            problems.append(f"{name}.{missing}: in the runtime's model, not in types.ts")
        for extra in sorted(set(fields) - set(properties)):
            problems.append(f"{name}.{extra}: in types.ts, not in the runtime's model")
        for field in sorted(set(fields) & set(properties)):
            kind, optional = fields[field]
            theirs = normal(schema_shape(properties[field], schemas))
            ours = normal(ts_shape(kind, aliases))
            if ours != theirs:
                problems.append(f"{name}.{field}: types.ts says {kind}, the runtime {theirs}")
            if optional and field in schemas[name].get("required", []):
                problems.append(f"{name}.{field}: always sent, but optional in types.ts")
    assert problems == [], "\n".join(problems)


def test_the_check_finds_a_field_that_drifted(schemas: dict[str, Any]) -> None:
    _, aliases = typescript()
    state = schemas["RobotState"]["properties"]
    assert normal(schema_shape(state["tool_open"], schemas)) == normal(
        ts_shape("boolean | null", aliases)
    )
    assert normal(schema_shape(state["tool_open"], schemas)) != normal(ts_shape("boolean", aliases))
    assert normal(schema_shape(state["command_mode"], schemas)) != normal(
        ts_shape('"halt" | "jog"', aliases)
    )
