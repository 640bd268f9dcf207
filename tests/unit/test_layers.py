"""The layers of DESIGN.md §1, read from the imports of every module: the robotics core and
the interfaces import no service and no web framework, a service reaches another service
only through that service's `client` module, no module imports one of a layer above its own,
and no module imports itself back through others (no cycles, type-only imports included)."""

from __future__ import annotations

import ast
import subprocess
import sys
from collections.abc import Iterable, Iterator, Mapping
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


# The layers, lowest first: each module imports only from its own layer and those below.
FOUNDATION, CORE, CLIENTS, SERVICES, TOP = range(5)
LAYERS = {
    # What everything stands on: the service kit, sign-in, where services are, the plugin API.
    "runtime": FOUNDATION,  # the package itself (its version)
    "runtime.kit": FOUNDATION,
    "runtime.auth": FOUNDATION,
    "runtime.services": FOUNDATION,
    "plugins": FOUNDATION,
    "plugins.api": FOUNDATION,
    "plugins.registry": FOUNDATION,
    # The interfaces and the robotics core.
    "runtime.interfaces": CORE,
    "runtime.robotics": CORE,
    "runtime.imaging": CORE,
    "runtime.paths": CORE,
    # Typed clients and links (a service's `client` and `models` too), the driver kit and the
    # drivers, the sandbox and the blocks, the cell model the services share.
    "runtime.links": CLIENTS,
    "runtime.clients": CLIENTS,
    "runtime.cell": CLIENTS,
    "runtime.drivers": CLIENTS,
    "device_drivers": CLIENTS,
    "sandbox": CLIENTS,
    "blockly_blocks": CLIENTS,
    # Above everything: the gateway, the launcher and command, the built-ins' registrations
    # (plugins: nothing imports them) and the example plugin.
    "webui": TOP,
    "runtime.launcher": TOP,
    "runtime.cli": TOP,
    "runtime.plugin": TOP,
    "device_drivers.plugin": TOP,
    "blockly_blocks.plugin": TOP,
    "plugins.conveyor": TOP,
}


def layer(module: str) -> int | None:
    service = service_of(module)
    if service is not None:
        # Its client and the models on its wire are what others use of a service.
        wire = (f"{service}.client", f"{service}.models")
        return CLIENTS if module in wire else SERVICES
    prefixes = [p for p in LAYERS if module == p or module.startswith(p + ".")]
    return LAYERS[max(prefixes, key=len)] if prefixes else None


def import_graph() -> dict[str, set[str]]:
    """Each module and the project's modules it imports."""
    found = dict(every_module())
    return {
        module: {name for _, name in imports(path, module) if name in found and name != module}
        for module, path in found.items()
    }


def upward(graph: Mapping[str, Iterable[str]]) -> list[str]:
    return sorted(
        f"{module} (layer {layer(module)}) imports {name} (layer {layer(name)})"
        for module, names in graph.items()
        for name in names
        if (layer(name) or 0) > (layer(module) or 0)
    )


def cycles(graph: Mapping[str, Iterable[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm,
    iterative: no recursion limit to meet)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(graph[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, edges = work[-1]
            step = next(edges, None)
            if step is not None:
                if step not in index:
                    index[step] = low[step] = len(index)
                    stack.append(step)
                    on_stack.add(step)
                    work.append((step, iter(graph.get(step, ()))))
                elif step in on_stack:
                    low[node] = min(low[node], index[step])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_every_module_has_a_layer() -> None:
    assert [m for m, _ in every_module() if layer(m) is None] == []


def test_no_module_imports_from_a_layer_above_its_own() -> None:
    assert upward(import_graph()) == []


def test_no_module_imports_itself_back() -> None:
    assert cycles(import_graph()) == []


def test_the_layer_and_cycle_checks_catch_what_they_are_for() -> None:
    """Fed a graph that breaks each rule: a core module importing a service, a driver
    importing the launcher, two blocks modules importing each other (as generator.py and
    standard.py did), and a longer loop."""
    graph = {
        "runtime.robotics.kinematics": {"runtime.motion.service"},
        "device_drivers.sim_robot.core": {"runtime.launcher.run", "runtime.interfaces.robot"},
        "runtime.motion.service": {"runtime.jog.client", "runtime.interfaces.robot"},
        "blockly_blocks.generator": {"blockly_blocks.standard"},
        "blockly_blocks.standard": {"blockly_blocks.generator"},
        "sandbox.a": {"sandbox.b"},
        "sandbox.b": {"sandbox.c"},
        "sandbox.c": {"sandbox.a"},
    }
    assert upward(graph) == [
        "device_drivers.sim_robot.core (layer 2) imports runtime.launcher.run (layer 4)",
        "runtime.robotics.kinematics (layer 1) imports runtime.motion.service (layer 3)",
    ]
    assert sorted(cycles(graph)) == [
        ["blockly_blocks.generator", "blockly_blocks.standard"],
        ["sandbox.a", "sandbox.b", "sandbox.c"],
    ]


# The simulated cell (its parts and frames) that every simulator shares: not a driver.
SHARED_BY_DRIVERS = "device_drivers.sim_cell"


def drivers_borrowing(graph: Mapping[str, Iterable[str]]) -> list[str]:
    """A driver's imports of another driver's package (the UR emulator's arm controller was
    the simulated robot's tracker; what several drivers need is in the robotics core or the
    driver kit, runtime.drivers)."""

    def driver(module: str) -> str | None:
        parts = module.split(".")
        if parts[0] != "device_drivers" or len(parts) < 2 or parts[1] == "plugin":
            return None
        return ".".join(parts[:2])

    return sorted(
        f"{module} imports {name}"
        for module, names in graph.items()
        for name in names
        if driver(module) is not None
        and driver(name) not in (None, driver(module), SHARED_BY_DRIVERS)
    )


def test_a_driver_takes_nothing_from_another_driver() -> None:
    assert drivers_borrowing(import_graph()) == []
    fed = {
        "device_drivers.ur_rtde.emulator.controller": {"device_drivers.sim_robot.tracker"},
        "device_drivers.sim_camera.driver": {"device_drivers.sim_cell.link"},
    }
    assert drivers_borrowing(fed) == [
        "device_drivers.ur_rtde.emulator.controller imports device_drivers.sim_robot.tracker"
    ]
