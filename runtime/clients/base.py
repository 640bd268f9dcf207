"""What every typed device client has: the device's one link (through the device manager),
its newest fresh state, and calls of its interface's endpoints on that link. A client
implements its kind's interface class, so a service holds the same abstract robot, gripper
or camera a driver implements, on the other side of the wire."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable, Callable
from typing import Any, ClassVar, Generic, TypeVar, cast

from pydantic import BaseModel

from openpendant.runtime.interfaces.endpoints import Endpoint
from openpendant.runtime.kit.errors import OpenPendantError, RobotError, Unavailable
from openpendant.runtime.kit.words import words_of
from openpendant.runtime.links.hub import DeviceView, LinkHub, Refusal

READY_TIMEOUT = 2.0

S = TypeVar("S", bound=BaseModel)
R = TypeVar("R")


def endpoint_of(method: Callable[..., Any]) -> Endpoint:
    declared = getattr(method, "__endpoint__", None)
    if not isinstance(declared, Endpoint):
        raise TypeError(f"{getattr(method, '__qualname__', method)} declares no endpoint")
    return declared


class DeviceClient(Generic[S]):
    kind: ClassVar[str]
    state_model: type[S]

    def __init__(self, hub: LinkHub, view: DeviceView) -> None:
        self.hub = hub
        self.view = view
        self.name = view.name
        self._on_error: Refusal | None = None
        view.on_refused = self._refused

    # State -----------------------------------------------------------------------------------

    @property
    def generation(self) -> int:
        return self.view.generation

    @property
    def description(self) -> dict[str, Any]:
        """The driver's GET /info, as the device manager read it on this link."""
        source = self.view.info
        if source is None:
            raise Unavailable(
                f"{self.name} has not described itself yet", code="device_disconnected"
            )
        return source

    async def ready(self, timeout: float = READY_TIMEOUT) -> DeviceClient[S]:
        """Waits for a fresh state; raises why there is none."""
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout):
                await self.view.ready.wait()
        self.current()
        return self

    def current(self, generation: int | None = None) -> S:
        """The newest state, if it is fresh (and on `generation`, if given)."""
        text = self.hub.state_text(self.view, generation)
        view = self.view
        if view.parsed is None:
            view.parsed = self.state_model.model_validate_json(text)
        state: S = view.parsed
        return state

    def latest(self) -> S | None:
        """The newest fresh state, or None."""
        try:
            return self.current()
        except OpenPendantError:
            return None

    # Refusals of streamed commands -----------------------------------------------------------

    @property
    def on_error(self) -> Refusal | None:
        return self._on_error

    @on_error.setter
    def on_error(self, handler: Refusal | None) -> None:
        self._on_error = handler

    def _refused(self, error: dict[str, Any]) -> None:
        if self._on_error is not None:
            self._on_error(error)

    # Calls -----------------------------------------------------------------------------------

    async def _call(
        self,
        method: Callable[..., Awaitable[R]],
        *args: Any,
        generation: int | None = None,
        claim: str | None = None,
    ) -> R:
        """Call an interface method on the driver over the link: its path filled with the
        leading arguments, its body the last one, its answer parsed as declared."""
        ep = endpoint_of(method)
        params = args[: len(ep.params)]
        body = args[len(ep.params)] if ep.body is not None and len(args) > len(ep.params) else None
        # A model goes as its JSON text, encoded once here and relayed as it is by the
        # device manager (a trajectory's thousands of numbers were parsed and encoded again
        # on the way).
        text = body.model_dump_json() if isinstance(body, BaseModel) else None
        gen = self.generation if generation is None else generation
        status, content = await self.hub.call(
            self.name, gen, ep.method, ep.url(*params), claim=claim, body_text=text
        )
        if status >= 400:
            raise _refusal(status, content, f"{ep.method} {ep.path}")
        if ep.returns is None:
            return cast(R, None)
        return cast(R, ep.returns.model_validate(content))


def _refusal(status: int, content: Any, what: str) -> OpenPendantError:
    if status == 409:  # a device's refusal (limits, mode, state)
        error = content.get("error", {}) if isinstance(content, dict) else {}
        message = str(error.get("message") or f"{what} was refused")
        code = str(error.get("code") or "device_error")
        return RobotError(message, code=code, words=words_of(error.get("words")))
    return OpenPendantError.from_body(status, content)
