"""The API as a browser sees it at the UI's port, in one OpenAPI document: every service's
routes below /api (as the gateway forwards them), the gateway's own, and each device kind's
state model (streamed over sockets, so in no route). The UI's typed client is generated from
it (`make ui`: openapi-typescript), and `openpendant openapi` prints it for other clients."""

from __future__ import annotations

import json
import tempfile
import warnings
from pathlib import Path
from typing import Any

from openpendant.plugins.api import resolve
from openpendant.plugins.registry import registry
from openpendant.runtime import __version__
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.services import WEBUI, load_factory, services

# The gateway's forwarding routes: what they forward is listed service by service instead.
FORWARDING = ("/api/{prefix}", "/api/{prefix}/{path}")
SCHEMAS = "#/components/schemas/"
NOT_TYPE = ("title", "description", "default")


class SchemaConflict(ValueError):
    """Two services name different models alike: a client could not tell them apart."""


def gateway_schema() -> dict[str, Any]:
    paths: dict[str, Any] = {}
    schemas: dict[str, Any] = {}
    urls = {spec.name: "http://127.0.0.1:9" for spec in services()}
    # No service is started; building the apps must not touch the user's data all the same.
    with tempfile.TemporaryDirectory(prefix="openpendant-openapi-") as scratch:
        settings = RuntimeSettings(data_dir=Path(scratch))
        for spec in (*services(), WEBUI):
            with warnings.catch_warnings():  # the forwarding routes' operation ids, left out
                warnings.simplefilter("ignore", UserWarning)
                document = load_factory(spec)(settings, urls).openapi()
            for path, item in document.get("paths", {}).items():
                if spec is WEBUI and path in FORWARDING:
                    continue
                paths[path if spec is WEBUI else f"/api{path}"] = item
            for name, schema in document.get("components", {}).get("schemas", {}).items():
                _add(schemas, name, schema, spec.name)
    for kind in registry().kinds.values():
        model = resolve(kind.state)
        # As sent: the routes' answers are described so too (every field always there).
        schema = model.model_json_schema(ref_template=SCHEMAS + "{model}", mode="serialization")
        for name, nested in schema.pop("$defs", {}).items():
            _add(schemas, name, nested, f"the {kind.name} kind")
        _add(schemas, model.__name__, schema, f"the {kind.name} kind")
    _all_sent(paths, schemas, [resolve(kind.state).__name__ for kind in registry().kinds.values()])
    return {
        "openapi": "3.1.0",
        "info": {"title": "OpenPendant", "version": __version__},
        "paths": dict(sorted(paths.items())),
        "components": {"schemas": dict(sorted(schemas.items()))},
    }


def _all_sent(paths: dict[str, Any], schemas: dict[str, Any], streamed: list[str]) -> None:
    """Every field of a model the runtime sends is in what it sends (no route leaves any
    out), and the UI counts on it; Pydantic describes an answer's fields that have a
    default as optional. Where a client also sends the model (a pose, a payload, a
    calibration board), the document asks it for every field: stricter than the runtime,
    never wrong for a client that follows it."""
    answers: set[str] = set(streamed)
    for item in paths.values():
        for operation in item.values():
            for code, response in operation.get("responses", {}).items():
                if code.startswith("2"):
                    answers |= _refs(response)
    for name in _reached(answers, schemas):
        schema = schemas[name]
        if "properties" in schema:
            schema["required"] = list(schema["properties"])


def _refs(schema: Any) -> set[str]:
    if isinstance(schema, dict):
        found = {str(schema["$ref"]).removeprefix(SCHEMAS)} if "$ref" in schema else set()
        return found.union(*(_refs(v) for v in schema.values()))
    if isinstance(schema, list):
        return set().union(*(_refs(v) for v in schema))
    return set()


def _reached(names: set[str], schemas: dict[str, Any]) -> set[str]:
    reached: set[str] = set()
    todo = list(names)
    while todo:
        name = todo.pop()
        if name not in reached and name in schemas:
            reached.add(name)
            todo += _refs(schemas[name])
    return reached


def _add(schemas: dict[str, Any], name: str, schema: dict[str, Any], source: str) -> None:
    known = schemas.get(name)
    if known is not None and _without_text(known) != _without_text(schema):
        raise SchemaConflict(f"{source}'s model {name!r} differs from another's of that name")
    schemas.setdefault(name, schema)


def _without_text(schema: Any, names: bool = False) -> Any:
    """A schema without what does not change its type: titles, descriptions (one service
    may word them otherwise) and defaults (FastAPI leaves some out of an answer's schema).
    `names`: a map of field names to schemas (a field may be called "title")."""
    if isinstance(schema, dict):
        return {
            k: _without_text(v, k in ("properties", "$defs"))
            for k, v in schema.items()
            if names or k not in NOT_TYPE
        }
    if isinstance(schema, list):
        return [_without_text(v) for v in schema]
    return schema


def write(out: Path | None) -> None:
    text = json.dumps(gateway_schema(), indent=1, sort_keys=False) + "\n"
    if out is None:
        print(text, end="")
        return
    out.parent.mkdir(parents=True, exist_ok=True)
    if not out.is_file() or out.read_text() != text:  # unchanged: make has nothing to redo
        out.write_text(text)
