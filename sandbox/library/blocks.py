"""Helpers behind Blockly's standard math, text and list blocks (what Blockly's own Python
generator would import from math and random). Positions are 1-based, as the blocks show."""

from __future__ import annotations

import math
import random
import statistics
from collections.abc import Callable
from typing import Any

from openpendant.sandbox.guards import SandboxError
from openpendant.sandbox.library.base import sandbox_function

MAX_RANGE = 10_000_000


def _list(value: Any, what: str = "list") -> list[Any]:
    if not isinstance(value, list):
        raise SandboxError(f"{what} must be a list, not {type(value).__name__}")
    return value


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _numbers(value: Any) -> list[float]:
    items = _list(value)
    if not all(_is_number(v) for v in items):
        raise SandboxError("that needs a list of numbers")
    return items


def _modes(items: list[Any]) -> list[Any]:
    """The most frequent items, in the order they first appear; lists among them too."""
    counts: list[list[Any]] = []  # [item, count]
    by_hash: dict[Any, list[Any]] = {}
    for item in items:
        try:
            entry = by_hash.setdefault(item, [item, 0])
        except TypeError:  # unhashable (a list): found by equality, as Blockly's code does
            entry = next((c for c in counts if c[0] == item), [item, 0])
        if entry[1] == 0:
            counts.append(entry)
        entry[1] += 1
    most = max((count for _, count in counts), default=0)
    return [item for item, count in counts if count == most]


@sandbox_function
def math_single(op: str, x: Any) -> Any:
    """ROOT, ABS, NEG, LN, LOG10, EXP or POW10 of x: a float, as Blockly's `math.fabs`,
    `math.sqrt`... give, but the negation of an integer is an integer (Blockly's `-x`)."""
    if op == "NEG":
        return -x
    table: dict[str, Callable[[Any], float]] = {
        "ROOT": math.sqrt,
        "ABS": abs,
        "LN": math.log,
        "LOG10": math.log10,
        "EXP": math.exp,
        "POW10": lambda v: 10.0**v,
    }
    if op not in table:
        raise SandboxError(f"unknown operation {op}")
    try:
        return float(table[op](x))
    except (ValueError, OverflowError) as exc:
        raise SandboxError(f"{op.lower()} of {x}: {exc}") from None


@sandbox_function
def math_trig(op: str, degrees_or_ratio: Any) -> float:
    """SIN, COS, TAN of an angle in degrees; ASIN, ACOS, ATAN in degrees."""
    x = degrees_or_ratio
    forward = {"SIN": math.sin, "COS": math.cos, "TAN": math.tan}
    inverse = {"ASIN": math.asin, "ACOS": math.acos, "ATAN": math.atan}
    try:
        if op in forward:
            return forward[op](math.radians(x))
        if op in inverse:
            return math.degrees(inverse[op](x))
    except ValueError as exc:
        raise SandboxError(f"{op.lower()} of {x}: {exc}") from None
    raise SandboxError(f"unknown operation {op}")


@sandbox_function
def math_atan2(x: Any, y: Any) -> float:
    """The angle of the point (x, y) in degrees."""
    return math.degrees(math.atan2(y, x))


@sandbox_function
def math_constant(name: str) -> float:
    table = {
        "PI": math.pi,
        "E": math.e,
        "GOLDEN_RATIO": (1 + math.sqrt(5)) / 2,
        "SQRT2": math.sqrt(2),
        "SQRT1_2": math.sqrt(0.5),
        "INFINITY": math.inf,
    }
    if name not in table:
        raise SandboxError(f"unknown constant {name}")
    return table[name]


@sandbox_function
def math_is(prop: str, x: Any, divisor: Any = None) -> bool:
    """EVEN, ODD, PRIME, WHOLE, POSITIVE, NEGATIVE or DIVISIBLE_BY divisor."""
    if prop == "EVEN":
        return bool(x % 2 == 0)
    if prop == "ODD":
        return bool(x % 2 == 1)
    if prop == "WHOLE":
        return bool(x % 1 == 0)
    if prop == "POSITIVE":
        return bool(x > 0)
    if prop == "NEGATIVE":
        return bool(x < 0)
    if prop == "DIVISIBLE_BY":
        return bool(divisor not in (0, None) and x % divisor == 0)
    if prop == "PRIME":
        if not isinstance(x, int):
            try:  # a text is read as a number, as in Blockly's math_isPrime
                x = float(x)
            except (TypeError, ValueError):
                return False
            if not math.isfinite(x) or not x.is_integer():
                return False
        return _is_prime(int(x))
    raise SandboxError(f"unknown property {prop}")


# Miller-Rabin with these bases is exact below 3.3e24, a strong probable-prime test beyond
# (Blockly's trial division takes minutes from about 10**18). Its time grows with the cube
# of the length: 0.3 s at 2203 bits, 21 s at 9941 here; any float is below 2**1024.
PRIME_BASES = (2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41)
PRIME_MAX_BITS = 1024


def _is_prime(n: int) -> bool:
    if n < 2:
        return False
    for p in PRIME_BASES:
        if n % p == 0:
            return n == p
    if n.bit_length() > PRIME_MAX_BITS:
        raise SandboxError(f"a number of more than {PRIME_MAX_BITS} bits is too large to test")
    d, s = n - 1, 0
    while d % 2 == 0:
        d, s = d // 2, s + 1
    for a in PRIME_BASES:
        x = pow(a, d, n)
        if x in (1, n - 1):
            continue
        for _ in range(s - 1):
            x = x * x % n
            if x == n - 1:
                break
        else:
            return False
    return True


@sandbox_function
def math_round(op: str, x: Any) -> float:
    table: dict[str, Callable[[Any], float]] = {
        "ROUND": round,
        "ROUNDUP": math.ceil,
        "ROUNDDOWN": math.floor,
    }
    if op not in table:
        raise SandboxError(f"unknown rounding {op}")
    return table[op](x)


@sandbox_function
def math_on_list(op: str, values: Any) -> Any:
    """SUM, MIN, MAX, AVERAGE, MEDIAN, MODE, STD_DEV or RANDOM of a list. As in Blockly, the
    average and the median are of the numbers in it, the modes of any items."""
    if op == "RANDOM":
        items = _list(values)
        return random.choice(items) if items else None
    if op == "MODE":
        return _modes(_list(values))
    if op in ("AVERAGE", "MEDIAN"):
        values = [v for v in _list(values) if _is_number(v)]
    numbers = _numbers(values)
    if op == "SUM":
        return sum(numbers)
    if not numbers:
        return None if op != "MODE" else []
    table: dict[str, Callable[[list[float]], Any]] = {
        "MIN": min,
        "MAX": max,
        "AVERAGE": statistics.fmean,
        "MEDIAN": statistics.median,
        "STD_DEV": statistics.pstdev,
    }
    if op not in table:
        raise SandboxError(f"unknown list operation {op}")
    return table[op](numbers)


@sandbox_function
def math_constrain(x: Any, low: Any, high: Any) -> Any:
    return min(max(x, low), high)


@sandbox_function
def random_int(low: Any, high: Any) -> int:
    a, b = sorted((int(low), int(high)))
    return random.randint(a, b)


@sandbox_function
def random_fraction() -> float:
    return random.random()


@sandbox_function
def count_range(start: Any, stop: Any, step: Any) -> Any:
    """Blockly's "count with i from a to b by c": inclusive, counting down when a > b."""
    step = abs(step) or 1
    values = [start, stop, step]
    if all(isinstance(v, int) for v in values):
        return range(start, stop + 1, step) if start <= stop else range(start, stop - 1, -step)
    if abs(stop - start) / step > MAX_RANGE:
        raise SandboxError("that count has too many steps")
    out, x = [], start
    if start <= stop:
        while x <= stop:
            out.append(x)
            x += step
    else:
        while x >= stop:
            out.append(x)
            x -= step
    return out


def _index(items: Any, where: str, at: Any, *, insert: bool = False) -> int:
    """A 0-based index for FROM_START / FROM_END / FIRST / LAST / RANDOM."""
    size = len(items)
    if where == "FIRST":
        return 0
    if where == "LAST":
        return size if insert else size - 1
    if where == "RANDOM":
        # Blockly's `int(random.random() * len(x))`: an item's place, also to insert at
        # (never after the last item), and the start of an empty list.
        if size == 0 and not insert:
            raise SandboxError("cannot pick from an empty list")
        return random.randrange(size) if size else 0
    if not _is_number(at):
        raise SandboxError("a position is a number")
    if where == "FROM_START":
        return int(at) - 1
    if where == "FROM_END":  # to insert: before the item there, as Blockly's `insert(-at, …)`
        return size - int(at)
    raise SandboxError(f"unknown position {where}")


@sandbox_function
def item_get(items: Any, mode: str, where: str, at: Any = None) -> Any:
    """GET, GET_REMOVE or REMOVE the item at a position of a list or text."""
    if isinstance(items, str) and mode == "GET":
        i = _index(items, where, at)
        if not 0 <= i < len(items):
            raise SandboxError(f"there is no letter #{i + 1} in a text of {len(items)}")
        return items[i]
    seq = _list(items)
    i = _index(seq, where, at)
    if not 0 <= i < len(seq):
        raise SandboxError(f"there is no item #{i + 1} in a list of {len(seq)}")
    return seq[i] if mode == "GET" else seq.pop(i)


@sandbox_function
def item_set(items: Any, mode: str, where: str, at: Any, value: Any) -> None:
    """SET or INSERT an item at a position of a list."""
    seq = _list(items)
    i = _index(seq, where, at, insert=mode == "INSERT")
    if mode == "INSERT":
        if not 0 <= i <= len(seq):
            raise SandboxError(f"cannot insert at #{i + 1} in a list of {len(seq)}")
        seq.insert(i, value)
        return
    if not 0 <= i < len(seq):
        raise SandboxError(f"there is no item #{i + 1} in a list of {len(seq)}")
    seq[i] = value


@sandbox_function
def sub_sequence(items: Any, where1: str, at1: Any, where2: str, at2: Any) -> Any:
    """The part of a list or text between two positions, both included."""
    if not isinstance(items, list | str):
        raise SandboxError("that needs a list or a text")
    start = _index(items, where1, at1)
    end = _index(items, where2, at2)
    return items[max(start, 0) : max(end + 1, 0)]


@sandbox_function
def find_first(items: Any, item: Any) -> int:
    """Position (1-based) of the first occurrence, 0 if absent."""
    return items.index(item) + 1 if item in items else 0


@sandbox_function
def find_last(items: Any, item: Any) -> int:
    """Position (1-based) of the last occurrence, 0 if absent."""
    if isinstance(items, str):
        return items.rfind(item) + 1
    seq = _list(items)
    for i in range(len(seq) - 1, -1, -1):
        if seq[i] == item:
            return i + 1
    return 0


def _sort_number(value: Any) -> float:
    """A number to sort by; what is none sorts as 0, as in Blockly's `try_float`."""
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return 0.0


@sandbox_function
def sort_list(items: Any, kind: str, direction: Any) -> list[Any]:
    seq = list(_list(items))
    keys: dict[str, Callable[[Any], Any]] = {
        "NUMERIC": _sort_number,
        "TEXT": lambda v: str(v),
        "IGNORE_CASE": lambda v: str(v).lower(),
    }
    if kind not in keys:
        raise SandboxError(f"unknown sort {kind}")
    try:
        return sorted(seq, key=keys[kind], reverse=direction == -1)
    except (TypeError, ValueError) as exc:
        raise SandboxError(f"cannot sort that list: {exc}") from None


@sandbox_function
def text_join(*parts: Any) -> str:
    return "".join(str(p) for p in parts)


@sandbox_function
def text_title(text: Any) -> str:
    return str(text).title()
