"""The layers of DESIGN.md §1, read from the imports of every module: the robotics core and
the interfaces import no service and no web framework, and a service reaches another service
only through that service's `client` module."""

from __future__ import annotations

import ast
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from runtime.services import services

ROOT = Path(__file__).resolve().parents[2]
SERVICE_PACKAGES = {spec.factory.split(":")[0].rsplit(".", 1)[0] for spec in services()}
WEB = ("fastapi", "starlette", "uvicorn", "httpx", "websockets")
PURE = ("runtime.robotics", "runtime.interfaces", "runtime.imaging")


def modules(package_dir: Path) -> Iterator[tuple[str, Path]]:
    for path in sorted(package_dir.rglob("*.py")):
        relative = path.relative_to(ROOT).with_suffix("")
        parts = relative.parts[:-1] if relative.name == "__init__" else relative.parts
        yield ".".join(parts), path


def imports(path: Path, module: str) -> Iterator[tuple[int, str]]:
    """Every module a file imports (absolute names, relative imports resolved)."""
    tree = ast.parse(path.read_text(), str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            yield node.lineno, base
            for alias in node.names:  # `from runtime.motion import client`
                yield node.lineno, f"{base}.{alias.name}"


def service_of(module: str) -> str | None:
    for package in SERVICE_PACKAGES:
        if module == package or module.startswith(package + "."):
            return package
    return None


# The benchmarks time a service's inner loops in-process (the velocity QP step, planning),
# as tests do: like tests, they are not a layer.
MEASURING = "runtime.bench"


def every_module() -> Iterator[tuple[str, Path]]:
    for top in ("runtime", "device_drivers", "sandbox", "blockly_blocks", "plugins", "webui"):
        for module, path in modules(ROOT / top):
            if not module.startswith(MEASURING):
                yield module, path


def test_the_service_packages_are_known() -> None:
    assert {"runtime.jog", "runtime.motion", "runtime.program"} <= SERVICE_PACKAGES


def test_a_service_reaches_another_only_through_its_client() -> None:
    found = []
    for module, path in every_module():
        own = service_of(module)
        for line, imported in imports(path, module):
            other = service_of(imported)
            if other is None or other == own:
                continue
            if imported == other or imported.startswith(f"{other}.client"):
                continue
            found.append(f"{path.relative_to(ROOT)}:{line} imports {imported}")
    assert not found, "\n".join(sorted(set(found)))


def test_the_core_imports_no_service_and_no_web_framework() -> None:
    found = []
    for module, path in every_module():
        if not module.startswith(PURE):
            continue
        for line, imported in imports(path, module):
            top = imported.split(".")[0]
            if service_of(imported) or top in WEB or imported.startswith(("runtime.links",)):
                found.append(f"{path.relative_to(ROOT)}:{line} imports {imported}")
    assert not found, "\n".join(found)


def test_the_walk_sees_a_forbidden_import(tmp_path: Path) -> None:
    """The checks above read real imports: a file that breaks the rule is caught."""
    bad = tmp_path / "bad.py"
    bad.write_text("from runtime.motion.moves import MovePlanner\nimport fastapi\n")
    seen = [name for _, name in imports(bad, "runtime.jog.bad")]
    assert "runtime.motion.moves" in seen
    assert service_of("runtime.motion.moves") == "runtime.motion"
    assert "fastapi" in seen


def test_the_robotics_core_loads_no_web_framework_or_network_library_even_indirectly() -> None:
    """What importing every module of the core pulls in, in a fresh interpreter: the
    import walk above reads only each file's own imports."""
    core = [m for m, _ in modules(ROOT / "runtime" / "robotics")]
    script = (
        "import importlib, sys\n"
        f"for m in {core!r}: importlib.import_module(m)\n"
        "print('\\n'.join(sorted(sys.modules)))\n"
    )
    loaded = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=ROOT
    ).stdout.split()
    banned = (*WEB, "zeroconf", "pydantic_settings", *SERVICE_PACKAGES)
    found = [m for m in loaded if any(m == b or m.startswith(b + ".") for b in banned)]
    assert found == []
