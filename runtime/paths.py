"""Where the project's data lives: robot-info YAMLs, URDF packages, the built UI."""

from __future__ import annotations

import site
import sys
import sysconfig
from functools import cache
from pathlib import Path

from openpendant import deploy
from openpendant.runtime.kit.errors import NotFound
from openpendant.runtime.robotics.dh_urdf import GENERATED_PACKAGE, generated_dir

# Package data (deploy/robots), found the same in a source checkout and an installed runtime.
DEPLOY_DIR = Path(deploy.__file__).resolve().parent
ROBOTS_DIR = DEPLOY_DIR / "robots"
MODBUS_MAPS_DIR = DEPLOY_DIR / "modbus"  # register maps of Modbus I/O blocks


@cache
def _installed_roots() -> dict[str, Path]:
    roots: dict[str, Path] = {}
    # The environment's site-packages first, then anything else on the path (PYTHONPATH).
    candidates = [sysconfig.get_paths()["purelib"], *site.getsitepackages(), *sys.path]
    for base in candidates:
        share = Path(base) / "cmeel.prefix" / "share" / "example-robot-data"
        if share.is_dir():
            roots["example-robot-data"] = share
            break
    return roots


def package_roots() -> dict[str, Path]:
    """URDF `package://` names and the folders they stand for."""
    # URDFs made from DH parameters live in a cache named by the environment.
    return {**_installed_roots(), GENERATED_PACKAGE: generated_dir()}


def resolve_package_uri(uri: str, relative_to: Path | None = None) -> Path:
    """Turn `package://pkg/sub/path`, `file:///abs` or a plain path into a file on disk."""
    if uri.startswith("package://"):
        package, _, rest = uri[len("package://") :].partition("/")
        roots = package_roots()
        if package not in roots:
            raise NotFound(f"URDF package {package!r} is not installed", code="unknown_package")
        path = roots[package] / rest
    elif uri.startswith("file://"):
        path = Path(uri[len("file://") :])
    else:
        path = Path(uri)
        if not path.is_absolute() and relative_to is not None:
            path = relative_to / path
    if not path.is_file():
        raise NotFound(f"file not found: {uri}", code="file_not_found")
    return path
