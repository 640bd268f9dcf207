"""Typed async client for calling another service or a device driver over HTTP."""

from __future__ import annotations

from typing import Any, TypeVar, overload

# httpx's async transport imports anyio's asyncio backend at its first request: 137 ms with
# a service's event loop held (seen in jog). Imported here, before the launcher forks its
# services, it is loaded once and shared.
import anyio._backends._asyncio  # noqa: F401
import httpx
from pydantic import BaseModel

from openpendant.runtime.kit.errors import OpenPendantError, Unavailable
from openpendant.runtime.kit.internal import internal_headers

M = TypeVar("M", bound=BaseModel)

# httpx makes an SSL context for every client made with its defaults (the CA bundle read and
# parsed: about 30 ms of CPU, with the event loop held), even for a client that only ever
# speaks plain HTTP. Every client shares this one, made once per process: a halt sent to a
# device's other addresses makes a client of its own and must not wait for that.
CLIENT_TLS = httpx.create_ssl_context()


class ServiceClient:
    """Errors come back as OpenPendantError with the remote code and status."""

    def __init__(self, base_url: str, *, timeout: float = 5.0, name: str | None = None) -> None:
        self.base_url = base_url.rstrip("/")
        self.name = name or self.base_url
        self._http = httpx.AsyncClient(
            base_url=self.base_url,
            timeout=timeout,
            headers=internal_headers(self.base_url),
            verify=CLIENT_TLS,
        )

    async def aclose(self) -> None:
        await self._http.aclose()

    async def __aenter__(self) -> ServiceClient:
        return self

    async def __aexit__(self, *_: object) -> None:
        await self.aclose()

    @overload
    async def request(
        self,
        method: str,
        path: str,
        *,
        json: Any = ...,
        params: dict[str, Any] | None = ...,
        model: type[M],
        timeout: float | None = ...,
        headers: dict[str, str] | None = ...,
    ) -> M: ...

    @overload
    async def request(
        self,
        method: str,
        path: str,
        *,
        json: Any = ...,
        params: dict[str, Any] | None = ...,
        model: None = ...,
        timeout: float | None = ...,
        headers: dict[str, str] | None = ...,
    ) -> Any: ...

    async def request(
        self,
        method: str,
        path: str,
        *,
        json: Any = None,
        params: dict[str, Any] | None = None,
        model: type[M] | None = None,
        timeout: float | None = None,
        headers: dict[str, str] | None = None,
    ) -> Any:
        kwargs: dict[str, Any] = {"json": json, "params": params, "headers": headers}
        if timeout is not None:
            kwargs["timeout"] = timeout
        try:
            response = await self._http.request(method, path, **kwargs)
        except httpx.TransportError as exc:
            raise Unavailable(
                f"{self.name} is unreachable ({type(exc).__name__})", code="unreachable"
            ) from exc
        if response.status_code >= 300 and response.status_code < 400:
            # Services never redirect one another: a redirect means the path named no route.
            raise Unavailable(
                f"{self.name} answered {response.status_code} to {method} {path}",
                code="unexpected_answer",
            )
        if response.status_code >= 400:
            try:
                body = response.json()
            except ValueError:
                body = None
            raise OpenPendantError.from_body(response.status_code, body)
        if not response.content:
            return None
        data = response.json()
        return model.model_validate(data) if model is not None else data

    async def get(self, path: str, **kwargs: Any) -> Any:
        return await self.request("GET", path, **kwargs)

    async def post(self, path: str, **kwargs: Any) -> Any:
        return await self.request("POST", path, **kwargs)

    async def put(self, path: str, **kwargs: Any) -> Any:
        return await self.request("PUT", path, **kwargs)

    async def delete(self, path: str, **kwargs: Any) -> Any:
        return await self.request("DELETE", path, **kwargs)
