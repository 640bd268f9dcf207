"""The builtins a program sees: plain data, arithmetic and iteration; nothing that reaches
the interpreter, the file system or other objects' insides."""

from __future__ import annotations

import builtins
from typing import Any

from openpendant.sandbox.guards import guarded_pow

SAFE_NAMES = [
    "None",
    "False",
    "True",
    "abs",
    "all",
    "any",
    "bool",
    "chr",
    "divmod",
    "enumerate",
    "filter",
    "float",
    "frozenset",
    "int",
    "isinstance",
    "len",
    "list",
    "map",
    "max",
    "min",
    "ord",
    "range",
    "repr",
    "reversed",
    "round",
    "set",
    "slice",
    "sorted",
    "str",
    "sum",
    "tuple",
    "zip",
    "dict",
    "hex",
    "oct",
    "bin",
    "callable",
    "ArithmeticError",
    "AssertionError",
    "Exception",
    "IndexError",
    "KeyError",
    "LookupError",
    "OverflowError",
    "RuntimeError",
    "TimeoutError",
    "TypeError",
    "ValueError",
    "ZeroDivisionError",
]


def safe_builtins() -> dict[str, Any]:
    table = {name: getattr(builtins, name) for name in SAFE_NAMES}
    table["pow"] = guarded_pow
    return table
