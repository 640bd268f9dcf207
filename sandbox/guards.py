"""The run-time half of the policy: what `a.b`, `a[b]`, `a[b] = c`, `for x in a`, `a += b`
and `a ** b` may do in a program. Attribute access is an allow-list per type: the plain data
types' public methods (less str.format and str.format_map, which reach attributes through
the format string) and the attributes a sandbox value declares; nothing else, so the
objects the interpreter hands out (functions, generators, frames, exceptions) stay closed."""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Iterable, Iterator
from typing import Any

from RestrictedPython.Guards import guarded_iter_unpack_sequence, guarded_unpack_sequence
from RestrictedPython.transformer import INSPECT_ATTRIBUTES

MAX_POW_BITS = 100_000  # ~30,000 decimal digits
MAX_SEQUENCE_REPEAT = 10_000_000


class SandboxError(Exception):
    """A program did something the sandbox does not allow."""


def _public(kind: type, *, drop: frozenset[str] = frozenset()) -> frozenset[str]:
    return frozenset(n for n in dir(kind) if not n.startswith("_")) - drop


ALLOWED_ATTRIBUTES: dict[type, frozenset[str]] = {
    str: _public(str, drop=frozenset({"format", "format_map"})),
    list: _public(list),
    tuple: _public(tuple),
    dict: _public(dict),
    set: _public(set),
    frozenset: _public(frozenset),
    int: _public(int),
    float: _public(float),
    bool: _public(bool),
    range: frozenset({"start", "stop", "step", "count", "index"}),
}
SUBSCRIPTABLE = (list, tuple, dict, str, range)
WRITABLE = (list, dict, set)


def register_value_type(kind: type, attributes: Iterable[str]) -> None:
    """Let programs read these attributes of a sandbox value type."""
    names = frozenset(attributes)
    bad = [n for n in names if n.startswith("_") or n in INSPECT_ATTRIBUTES]
    if bad:
        raise ValueError(f"{kind.__name__} cannot expose {bad}")
    ALLOWED_ATTRIBUTES[kind] = names


def guarded_getattr(obj: Any, name: str, *default: Any) -> Any:
    if not isinstance(name, str):
        raise SandboxError("attribute names are text")
    allowed = ALLOWED_ATTRIBUTES.get(type(obj))
    if name.startswith("_") or name in INSPECT_ATTRIBUTES or allowed is None or name not in allowed:
        raise SandboxError(f"{type(obj).__name__}.{name} is not available in programs")
    return getattr(obj, name, *default)


def guarded_getitem(obj: Any, key: Any) -> Any:
    if not isinstance(obj, SUBSCRIPTABLE):
        raise SandboxError(f"a {type(obj).__name__} cannot be indexed in programs")
    return obj[key]


def guarded_write(obj: Any) -> Any:
    """`obj[k] = v`, `del obj[k]` and `obj.a = v` go through here first."""
    if type(obj) not in WRITABLE:
        raise SandboxError(f"a {type(obj).__name__} cannot be changed by programs")
    return obj


def guarded_iter(obj: Any) -> Iterator[Any]:
    return iter(obj)


def guarded_pow(base: Any, exponent: Any, modulo: Any = None) -> Any:
    if modulo is None and isinstance(base, int) and isinstance(exponent, int) and exponent > 0:
        magnitude = abs(base)
        if magnitude > 1 and exponent * math.log2(magnitude) > MAX_POW_BITS:
            raise SandboxError(
                f"{base} ** {exponent} has more than {MAX_POW_BITS} bits; too large to compute"
            )
    if modulo is None:
        return base**exponent
    return pow(base, exponent, modulo)


def _repeat_checked(op: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
    def apply(a: Any, b: Any) -> Any:
        for seq, count in ((a, b), (b, a)):
            sequence = isinstance(seq, str | list | tuple) and isinstance(count, int)
            if sequence and len(seq) * count > MAX_SEQUENCE_REPEAT:
                raise SandboxError("that repetition makes a sequence too long")
        return op(a, b)

    return apply


INPLACE_OPS: dict[str, Callable[[Any, Any], Any]] = {
    "+=": operator.add,
    "-=": operator.sub,
    "*=": _repeat_checked(operator.mul),
    "/=": operator.truediv,
    "//=": operator.floordiv,
    "%=": operator.mod,
    "**=": guarded_pow,
    "<<=": operator.lshift,
    ">>=": operator.rshift,
    "&=": operator.and_,
    "|=": operator.or_,
    "^=": operator.xor,
}


def guarded_inplace(op: str, target: Any, value: Any) -> Any:
    fn = INPLACE_OPS.get(op)
    if fn is None:
        raise SandboxError(f"the operator {op} is not available in programs")
    # Lists extend in place, like Python's own `+=`.
    if op == "+=" and type(target) is list:
        target.extend(value)
        return target
    return fn(target, value)


def guarded_apply(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    return fn(*args, **kwargs)


def guard_globals() -> dict[str, Any]:
    """The hidden names RestrictedPython's compiled code calls."""
    return {
        "_getattr_": guarded_getattr,
        "_getitem_": guarded_getitem,
        "_write_": guarded_write,
        "_getiter_": guarded_iter,
        "_iter_unpack_sequence_": guarded_iter_unpack_sequence,
        "_unpack_sequence_": guarded_unpack_sequence,
        "_inplacevar_": guarded_inplace,
        "_apply_": guarded_apply,
        "_pow_": guarded_pow,
    }
