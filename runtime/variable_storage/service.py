"""The variable storage service: REST, YAML export/import and change notifications."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from typing import Annotated, Any

import yaml
from fastapi import APIRouter, FastAPI, Query, Request, Response, WebSocket
from pydantic import BaseModel, Field

from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.interfaces.variables import Variable
from openpendant.runtime.kit.app import create_app
from openpendant.runtime.kit.bodies import YAML_TEXT
from openpendant.runtime.kit.bounded_yaml import load_yaml
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.kit.websocket import Fanout
from openpendant.runtime.variable_storage.store import HistoryEntry, VariableStore
from openpendant.runtime.variable_storage.types import types

MAX_IMPORT_BYTES = 64 * 1024 * 1024


class PutVariable(Strict):
    type: str
    value: Any
    tags: list[str] | None = None
    doc: str | None = Field(default=None, max_length=10_000)
    expected_version: int | None = Field(default=None, ge=0, le=2**53)
    # Who writes (a program's run: "program:<name>") and the bytes its versions may occupy,
    # history included: the write is refused (409 storage_full) past it.
    writer: str | None = Field(default=None, max_length=128)
    budget: int | None = Field(default=None, ge=0, le=2**53)


class Imported(BaseModel):
    imported: int  # variables written


class RenameVariable(Strict):
    to: str


def export_yaml(store: VariableStore) -> str:
    document = {
        "variables": [
            {"name": v.name, "type": v.type, "value": v.value, "tags": v.tags, "doc": v.doc}
            for v in store.query()
        ]
    }
    return yaml.safe_dump(document, sort_keys=False, allow_unicode=True)


def variables_router(store: VariableStore, changes: Fanout) -> APIRouter:
    router = APIRouter(prefix="/variables")

    def notify(event: str, variable: Variable) -> None:
        changes.publish_json({"type": event, "variable": variable.model_dump()})

    @router.get("")
    async def list_variables(
        tag: str | None = None, type: Annotated[str | None, Query()] = None
    ) -> list[Variable]:
        return await asyncio.to_thread(store.query, tag, type)

    @router.get("/_types")
    async def variable_types() -> dict[str, str]:
        return {name: t.description for name, t in sorted(types().items())}

    @router.get("/_export")
    async def export() -> Response:
        # Seconds of work for a big store: off the loop, which answers everyone else.
        text = await asyncio.to_thread(export_yaml, store)
        return Response(
            text,
            media_type="application/yaml",
            headers={"Content-Disposition": 'attachment; filename="openpendant-variables.yaml"'},
        )

    @router.post("/_import", openapi_extra=YAML_TEXT)
    async def import_variables(request: Request) -> Imported:
        raw = await request.body()
        if len(raw) > MAX_IMPORT_BYTES:
            raise InvalidValue("import file is too large", code="too_large")
        try:
            document = await asyncio.to_thread(load_yaml, raw)
        except yaml.YAMLError as exc:
            raise InvalidValue(f"not valid YAML: {exc}", code="invalid_import") from exc
        items = document.get("variables") if isinstance(document, dict) else None
        if not isinstance(items, list) or not all(isinstance(i, dict) for i in items):
            raise InvalidValue("expected a mapping with a 'variables' list", code="invalid_import")
        written = await asyncio.to_thread(store.put_many, items)
        for variable in written:
            notify("changed", variable)
        return Imported(imported=len(written))

    @router.websocket("/_events")
    async def events(ws: WebSocket) -> None:
        await changes.serve(ws)

    @router.get("/{name}")
    async def get_variable(name: str) -> Variable:
        return await asyncio.to_thread(store.get, name)

    @router.get("/{name}/history")
    async def history(name: str) -> list[HistoryEntry]:
        return await asyncio.to_thread(store.history, name)

    @router.put("/{name}")
    async def put_variable(name: str, body: PutVariable) -> Variable:
        variable = await asyncio.to_thread(
            store.put,
            name,
            body.type,
            body.value,
            tags=body.tags,
            doc=body.doc,
            expected_version=body.expected_version,
            writer=body.writer,
            budget=body.budget,
        )
        notify("changed", variable)
        return variable

    @router.post("/{name}/rename")
    async def rename(name: str, body: RenameVariable) -> Variable:
        old, new = await asyncio.to_thread(store.rename, name, body.to)
        notify("deleted", old)
        notify("changed", new)
        return new

    @router.delete("/{name}")
    async def delete_variable(
        name: str, expected_version: int | None = Query(None, ge=0, le=2**53)
    ) -> Variable:
        variable = await asyncio.to_thread(store.delete, name, expected_version)
        notify("deleted", variable)
        return variable

    return router


def build_app(settings: RuntimeSettings, urls: dict[str, str]) -> FastAPI:
    store = VariableStore(settings.data_dir / "variables.sqlite", settings.variable_history)
    changes = Fanout()

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        try:
            yield
        finally:
            store.close()

    async def health() -> dict[str, Any]:
        return {"database": str(store.path)}

    app = create_app("variable_storage", lifespan=lifespan, health=health)
    app.include_router(variables_router(store, changes))
    return app
