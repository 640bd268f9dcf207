"""Every HTTP client the product makes is given its TLS context: httpx's default builds one
per client (the CA bundle read and parsed, about 30 ms of CPU with the event loop held), so
a client made per request, such as a halt sent to a device's other addresses, would wait
for it."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import openpendant

PRODUCT = Path(openpendant.__file__).resolve().parent
CLIENTS = {"Client", "AsyncClient"}


def clients_without_a_context(source: str) -> list[int]:
    lines = []
    for node in ast.walk(ast.parse(source)):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr in CLIENTS
            and isinstance(node.func.value, ast.Name)
            and node.func.value.id == "httpx"
            and not any(k.arg == "verify" for k in node.keywords)
        ):
            lines.append(node.lineno)
    return lines


def test_the_check_finds_a_client_made_with_the_default() -> None:
    assert clients_without_a_context("import httpx\nc = httpx.AsyncClient(timeout=1)\n") == [2]
    assert clients_without_a_context("import httpx\nc = httpx.Client(verify=CONTEXT)\n") == []


def test_every_client_of_the_product_shares_a_context() -> None:
    found, read = {}, 0
    # The package's folders are links to the repository's (an editable install).
    for folder, dirs, files in os.walk(PRODUCT, followlinks=True):
        dirs[:] = [d for d in dirs if d not in ("node_modules", "__pycache__")]
        for name in files:
            path = Path(folder, name)
            relative = path.relative_to(PRODUCT)
            if path.suffix != ".py" or relative.parts[:2] == ("runtime", "bench"):
                continue  # benchmarks measure as a user's client would
            read += 1
            lines = clients_without_a_context(path.read_text())
            if lines:
                found[str(relative)] = lines
    assert read > 300
    assert found == {}


def test_the_async_backend_is_loaded_with_the_client_not_at_its_first_request() -> None:
    """Loaded at a service's first request it held the event loop 137 ms (jog's deadman is
    100 ms); loaded with the kit, the launcher has it before it forks the services."""
    check = (
        "import sys\nimport openpendant.runtime.kit.client\n"
        "assert 'anyio._backends._asyncio' in sys.modules\n"
    )
    done = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
