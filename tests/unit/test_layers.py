"""The layers of DESIGN.md §1, read from the imports of every module: the robotics core and
the interfaces import no service and no web framework, a service reaches another service
only through that service's `client` module, no module imports one of a layer above its own,
and no module imports itself back through others (no cycles, type-only imports included)."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

from openpendant.runtime.services import services

ROOT = Path(__file__).resolve().parents[2]
SERVICE_PACKAGES = {spec.factory.split(":")[0].rsplit(".", 1)[0] for spec in services()}
WEB = ("fastapi", "starlette", "uvicorn", "httpx", "websockets")
PURE = (
    "openpendant.runtime.robotics",
    "openpendant.runtime.interfaces",
    "openpendant.runtime.imaging",
)


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
            for alias in node.names:  # `from openpendant.runtime.motion import client`
                yield node.lineno, f"{base}.{alias.name}"


# A block category's handlers are the program service's answers to its blocks' calls, kept
# in the category's folder with the blocks (blockly_blocks/<category>/handlers.py).
BLOCK_HANDLERS = re.compile(r"openpendant\.blockly_blocks\.\w+\.handlers")


def service_of(module: str) -> str | None:
    if BLOCK_HANDLERS.fullmatch(module):
        return "openpendant.runtime.program"
    for package in SERVICE_PACKAGES:
        if module == package or module.startswith(package + "."):
            return package
    return None


# The benchmarks time a service's inner loops in-process (the velocity QP step, planning),
# as tests do: like tests, they are not a layer.
MEASURING = "openpendant.runtime.bench"


def every_module() -> Iterator[tuple[str, Path]]:
    for top in ("runtime", "device_drivers", "sandbox", "blockly_blocks", "plugins", "webui"):
        for module, path in modules(ROOT / "openpendant" / top):
            if not module.startswith(MEASURING):
                yield module, path


def test_the_service_packages_are_known() -> None:
    assert {
        "openpendant.runtime.jog",
        "openpendant.runtime.motion",
        "openpendant.runtime.program",
    } <= SERVICE_PACKAGES


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
            if (
                service_of(imported)
                or top in WEB
                or imported.startswith(("openpendant.runtime.links",))
            ):
                found.append(f"{path.relative_to(ROOT)}:{line} imports {imported}")
    assert not found, "\n".join(found)


def test_the_walk_sees_a_forbidden_import(tmp_path: Path) -> None:
    """The checks above read real imports: a file that breaks the rule is caught."""
    bad = tmp_path / "bad.py"
    bad.write_text("from openpendant.runtime.motion.moves import MovePlanner\nimport fastapi\n")
    seen = [name for _, name in imports(bad, "openpendant.runtime.jog.bad")]
    assert "openpendant.runtime.motion.moves" in seen
    assert service_of("openpendant.runtime.motion.moves") == "openpendant.runtime.motion"
    assert "fastapi" in seen


def test_the_robotics_core_loads_no_web_framework_or_network_library_even_indirectly() -> None:
    """What importing every module of the core pulls in, in a fresh interpreter: the
    import walk above reads only each file's own imports."""
    core = [m for m, _ in modules(ROOT / "openpendant" / "runtime" / "robotics")]
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
    "openpendant.runtime": FOUNDATION,  # the package itself (its version)
    "openpendant.runtime.kit": FOUNDATION,
    "openpendant.runtime.auth": FOUNDATION,
    "openpendant.runtime.services": FOUNDATION,
    "openpendant.plugins": FOUNDATION,
    "openpendant.plugins.api": FOUNDATION,
    "openpendant.plugins.registry": FOUNDATION,
    # The interfaces and the robotics core.
    "openpendant.runtime.interfaces": CORE,
    "openpendant.runtime.robotics": CORE,
    "openpendant.runtime.imaging": CORE,
    "openpendant.runtime.paths": CORE,
    # Typed clients and links (a service's `client` and `models` too), the driver kit and the
    # drivers, the sandbox and the blocks, the cell model the services share.
    "openpendant.runtime.links": CLIENTS,
    "openpendant.runtime.clients": CLIENTS,
    "openpendant.runtime.cell": CLIENTS,
    "openpendant.runtime.drivers": CLIENTS,
    "openpendant.device_drivers": CLIENTS,
    "openpendant.sandbox": CLIENTS,
    "openpendant.blockly_blocks": CLIENTS,
    "openpendant.plugins.robotraconteur": CLIENTS,  # drivers, in a plugin of the core's
    # Above everything: the gateway, the launcher and command, the built-ins' registrations
    # (plugins: nothing imports them) and the example plugin.
    "openpendant.webui": TOP,
    "openpendant.runtime.launcher": TOP,
    "openpendant.runtime.cli": TOP,
    "openpendant.runtime.plugin": TOP,
    "openpendant.device_drivers.plugin": TOP,
    "openpendant.blockly_blocks.plugin": TOP,
    "openpendant.plugins.conveyor": TOP,
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
        "openpendant.runtime.robotics.kinematics": {"openpendant.runtime.motion.service"},
        "openpendant.device_drivers.sim_robot.core": {
            "openpendant.runtime.launcher.run",
            "openpendant.runtime.interfaces.robot",
        },
        "openpendant.runtime.motion.service": {
            "openpendant.runtime.jog.client",
            "openpendant.runtime.interfaces.robot",
        },
        "openpendant.blockly_blocks.generator": {"openpendant.blockly_blocks.standard"},
        "openpendant.blockly_blocks.standard": {"openpendant.blockly_blocks.generator"},
        "openpendant.sandbox.a": {"openpendant.sandbox.b"},
        "openpendant.sandbox.b": {"openpendant.sandbox.c"},
        "openpendant.sandbox.c": {"openpendant.sandbox.a"},
    }
    assert upward(graph) == [
        "openpendant.device_drivers.sim_robot.core (layer 2) imports "
        "openpendant.runtime.launcher.run (layer 4)",
        "openpendant.runtime.robotics.kinematics (layer 1) imports "
        "openpendant.runtime.motion.service (layer 3)",
    ]
    assert sorted(cycles(graph)) == [
        ["openpendant.blockly_blocks.generator", "openpendant.blockly_blocks.standard"],
        ["openpendant.sandbox.a", "openpendant.sandbox.b", "openpendant.sandbox.c"],
    ]


# The simulated cell (its parts and frames) that every simulator shares: not a driver.
SHARED_BY_DRIVERS = "openpendant.device_drivers.sim_cell"


def drivers_borrowing(graph: Mapping[str, Iterable[str]]) -> list[str]:
    """A driver's imports of another driver's package (the UR emulator's arm controller was
    the simulated robot's tracker; what several drivers need is in the robotics core or the
    driver kit, openpendant.runtime.drivers)."""

    def driver(module: str) -> str | None:
        parts = module.split(".")
        if parts[:2] != ["openpendant", "device_drivers"] or len(parts) < 3 or parts[2] == "plugin":
            return None
        return ".".join(parts[:3])

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
        "openpendant.device_drivers.ur_rtde.emulator.controller": {
            "openpendant.device_drivers.sim_robot.tracker"
        },
        "openpendant.device_drivers.sim_camera.driver": {
            "openpendant.device_drivers.sim_cell.link"
        },
    }
    assert drivers_borrowing(fed) == [
        "openpendant.device_drivers.ur_rtde.emulator.controller imports "
        "openpendant.device_drivers.sim_robot.tracker"
    ]


BARE = ("runtime", "device_drivers", "sandbox", "blockly_blocks", "plugins", "webui", "deploy")


def test_the_project_is_imported_only_as_openpendant() -> None:
    """One installed package (issue 33): code and tests import `openpendant.runtime`, never
    `runtime` (which a checkout would also let them, and which would load a second copy of
    every module it reaches)."""
    found = []
    for path in sorted(ROOT.glob("[!.]*/**/*.py")):
        relative = path.relative_to(ROOT)
        if relative.parts[0] in ("openpendant", "build") or "build" in relative.parts:
            continue
        for line, name in imports(path, ".".join(relative.with_suffix("").parts)):
            if name.split(".")[0] in BARE:
                found.append(f"{relative}:{line} imports {name}")
    assert found == []


def test_loading_every_plugin_loads_nothing_outside_openpendant() -> None:
    """Every service, driver and block generator the plugins name, resolved in a fresh
    interpreter started away from the checkout: not one module under a bare name."""
    script = (
        "import sys\n"
        "from openpendant.plugins.api import resolve\n"
        "from openpendant.plugins.registry import registry\n"
        "plugins = registry()\n"
        "names = [s.factory for s in plugins.services.values()]\n"
        "names += [d.factory for d in plugins.drivers.values()]\n"
        "names += [b.generator for b in plugins.blocks.values()]\n"
        "for name in names: resolve(name)\n"
        "print(len(names)); print('\\n'.join(sorted(sys.modules)))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd="/"
    )
    count, *loaded = done.stdout.split()
    assert int(count) > 50
    assert [m for m in loaded if m.split(".")[0] in BARE] == []


def kind_name_checks(path: Path) -> list[int]:
    """Lines comparing a device's `.kind` with a kind's name (`record.kind == "robot"`)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.Compare):
            continue
        sides = [node.left, *node.comparators]
        named = any(isinstance(s, ast.Attribute) and s.attr == "kind" for s in sides)
        if named and any(isinstance(s, ast.Constant) and isinstance(s.value, str) for s in sides):
            found.append(node.lineno)
    return found


def test_the_device_manager_and_links_ask_a_kind_what_it_can_do_not_its_name(
    tmp_path: Path,
) -> None:
    """A kind declares its capabilities (a command session, a tool, frames: DeviceKind); the
    device manager and the links read those, so a plugin's kind gets the same treatment as
    a built-in one (issue 33: they tested `kind == "robot"`)."""
    found = [
        f"{path.relative_to(ROOT)}:{line}"
        for folder in ("device_manager", "links")
        for path in sorted((ROOT / "runtime" / folder).glob("*.py"))
        for line in kind_name_checks(path)
    ]
    assert found == []
    probe = tmp_path / "probe.py"
    probe.write_text(
        'if conn.record.kind != "camera":\n    pass\nif "robot" == view.kind:\n    pass\n'
    )
    assert kind_name_checks(probe) == [1, 3]


RR_PLUGIN = "openpendant.plugins.robotraconteur"
RR_MODULES = ("RobotRaconteur", "RobotRaconteurCompanion", "robotraconteur_abstract_robot")


def test_robot_raconteur_is_imported_only_by_its_plugin() -> None:
    """It is an optional extra (`openpendant[rr]`): the core runs without it installed."""
    found = [
        f"{module}:{line} imports {name}"
        for module, path in every_module()
        if not module.startswith(RR_PLUGIN)
        for line, name in imports(path, module)
        if name.split(".")[0] in RR_MODULES
    ]
    assert found == []
    # And the plugin's declaration imports none of it: loading the plugins needs no RR.
    declaration = ROOT / "openpendant" / "plugins" / "robotraconteur" / "__init__.py"
    assert [n for _, n in imports(declaration, RR_PLUGIN) if n.split(".")[0] in RR_MODULES] == []
