"""Typed client of the variable storage for other services."""

from __future__ import annotations

from typing import Any
from urllib.parse import quote

from openpendant.runtime.interfaces.variables import Variable
from openpendant.runtime.kit.client import ServiceClient


def _path(name: str) -> str:
    """A name is one path segment, whatever it holds (`x/../_export` is not a route)."""
    return quote(name, safe="")


class StorageClient:
    def __init__(self, base_url: str, timeout: float = 5.0) -> None:
        self.http = ServiceClient(base_url, timeout=timeout, name="variable storage")

    async def aclose(self) -> None:
        await self.http.aclose()

    async def get(self, name: str) -> Variable:
        return await self.http.request("GET", f"/variables/{_path(name)}", model=Variable)

    async def query(
        self, *, tag: str | None = None, type_name: str | None = None
    ) -> list[Variable]:
        params = {k: v for k, v in (("tag", tag), ("type", type_name)) if v is not None}
        data = await self.http.get("/variables", params=params)
        return [Variable.model_validate(item) for item in data]

    async def put(
        self,
        name: str,
        type_name: str,
        value: Any,
        *,
        tags: list[str] | None = None,
        doc: str | None = None,
        expected_version: int | None = None,
        writer: str | None = None,
        budget: int | None = None,
    ) -> Variable:
        body: dict[str, Any] = {"type": type_name, "value": value}
        if tags is not None:
            body["tags"] = tags
        if doc is not None:
            body["doc"] = doc
        if expected_version is not None:
            body["expected_version"] = expected_version
        if writer is not None:
            body["writer"] = writer
        if budget is not None:
            body["budget"] = budget
        return await self.http.request(
            "PUT", f"/variables/{_path(name)}", json=body, model=Variable
        )

    async def delete(self, name: str) -> Variable:
        return await self.http.request("DELETE", f"/variables/{_path(name)}", model=Variable)
