"""How a device interface declares its wire: each public method of an interface class names
its HTTP method, path, body and answer once, with `@endpoint`. The driver host generates the
driver's routes from these declarations, and the typed clients call the same declarations
over the device's link, so both sides of the wire are the one abstract class."""

from __future__ import annotations

import re
import typing
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, TypeVar
from urllib.parse import quote

from pydantic import BaseModel

Method = Literal["GET", "POST", "PUT", "DELETE"]
F = TypeVar("F", bound=Callable[..., Any])
PATH_PARAM = re.compile(r"\{([a-z_][a-z0-9_]*)\}")


@dataclass(frozen=True)
class Endpoint:
    name: str  # the interface method's name
    method: Method
    path: str  # may hold `{param}`s, passed to the method positionally, before the body
    body: type[BaseModel] | None
    returns: type[BaseModel] | None  # None: answered 204, no content
    # Also accepted as `{"type": stream, ...body}` on a robot's ordered command socket.
    stream: str | None
    # What the driver's command log calls an accepted call (default: the method's name).
    label: Callable[..., str] | None

    @property
    def params(self) -> list[str]:
        return PATH_PARAM.findall(self.path)

    @property
    def is_command(self) -> bool:
        return self.method != "GET"

    def url(self, *params: Any) -> str:
        """The path with its parameters filled in (for a client), each one a single path
        segment however it is spelled ("a/../b" cannot reach another route)."""
        if len(params) != len(self.params):
            raise ValueError(f"{self.name} takes {len(self.params)} path parameters")
        if any(str(p) in ("", ".", "..") for p in params):
            raise ValueError(f"{self.name}: a path parameter cannot be empty, '.' or '..'")
        values = iter(params)
        return PATH_PARAM.sub(lambda _: quote(str(next(values)), safe=""), self.path)

    def describe(self, args: tuple[Any, ...], result: Any = None) -> tuple[str, str | None]:
        """(label, tag) of an accepted call, for the driver's command log: the body's `tag`,
        else the id of what it started."""
        label = self.label(*args) if self.label is not None else self.name
        body = args[-1] if args and isinstance(args[-1], BaseModel) else None
        tag = getattr(body, "tag", None)
        if not isinstance(tag, str):
            tag = getattr(result, "id", None)
        return label, tag if isinstance(tag, str) else None


def endpoint(
    method: Method,
    path: str,
    *,
    body: type[BaseModel] | None = None,
    returns: type[BaseModel] | None = None,
    stream: str | None = None,
    label: Callable[..., str] | None = None,
) -> Callable[[F], F]:
    def mark(fn: F) -> F:
        fn.__endpoint__ = Endpoint(  # type: ignore[attr-defined]
            fn.__name__, method, path, body, returns, stream, label
        )
        return fn

    return mark


_DECLARED: dict[type[Any], dict[str, Endpoint]] = {}


def endpoints(interface: type[Any]) -> dict[str, Endpoint]:
    """Every endpoint an interface (and the interfaces it extends) declares, by method name."""
    found = _DECLARED.get(interface)
    if found is None:
        found = {}
        for klass in reversed(interface.__mro__):
            for name, member in vars(klass).items():
                declared = getattr(member, "__endpoint__", None)
                if isinstance(declared, Endpoint):
                    found[name] = declared
        _DECLARED[interface] = found
    return found


def param_types(interface: type, ep: Endpoint) -> dict[str, Any]:
    """The annotated types of an endpoint's path parameters (int or str)."""
    hints = typing.get_type_hints(getattr(interface, ep.name))
    return {name: hints.get(name, str) for name in ep.params}


def stream_commands(interface: type) -> dict[str, Endpoint]:
    """The endpoints a robot's command socket takes, by message type."""
    return {ep.stream: ep for ep in endpoints(interface).values() if ep.stream}
