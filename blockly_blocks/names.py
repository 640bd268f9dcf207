"""Python names for what users name freely in Blockly (variables, functions): made into
identifiers that collide with nothing the program needs (keywords, builtins, sandbox
functions) and with each other."""

from __future__ import annotations

import contextlib
import keyword
import re

from openpendant.plugins.api import resolve
from openpendant.plugins.registry import registry
from openpendant.sandbox.builtins import SAFE_NAMES
from openpendant.sandbox.library import REGISTRY
from openpendant.sandbox.policy import FORBIDDEN_NAMES


def sandbox_functions() -> set[str]:
    """The names programs call: the library's, every block's, and those the blocks'
    functions modules mark without a block naming them (importing a module registers them
    all, as it does in the worker)."""
    declared = {name: ref for b in registry().blocks.values() for name, ref in b.functions.items()}
    for reference in set(declared.values()):
        with contextlib.suppress(Exception):  # the worker leaves it out, and says why
            resolve(reference)
    return {*REGISTRY, *declared}


FUNCTIONS = sandbox_functions()
RESERVED = frozenset(
    {*keyword.kwlist, *keyword.softkwlist, *SAFE_NAMES, *FUNCTIONS, *FORBIDDEN_NAMES, "print"}
)
MAX_NAME = 60


class NameTable:
    def __init__(self) -> None:
        self._names: dict[tuple[str, str], str] = {}
        self._taken: set[str] = set(RESERVED)

    def get(self, kind: str, key: str, wanted: str | None = None) -> str:
        """The identifier for (kind, key), the same every time it is asked for; made from
        `wanted` (else the key) the first time."""
        found = self._names.get((kind, key))
        if found is not None:
            return found
        name = self.fresh(wanted if wanted is not None else key)
        self._names[(kind, key)] = name
        return name

    def fresh(self, wanted: str) -> str:
        """A new identifier like `wanted`, used by nothing else."""
        base = re.sub(r"\W", "_", wanted.strip(), flags=re.ASCII)[:MAX_NAME].strip("_")
        if not base or base[0].isdigit():
            base = f"v_{base}".rstrip("_")
        name, n = base, 2
        while name in self._taken:
            name, n = f"{base}{n}", n + 1
        self._taken.add(name)
        return name
