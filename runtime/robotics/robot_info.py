"""Robot-info YAML files: metadata, limits, URDF, flange and TCP of one robot model."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from openpendant.runtime.interfaces.robot import RobotInfo
from openpendant.runtime.kit.bounded_yaml import load_yaml
from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.paths import ROBOTS_DIR, resolve_package_uri
from openpendant.runtime.robotics.dh_urdf import DHArm, dh_urdf, write_generated
from openpendant.runtime.robotics.kinematics import load_urdf_model, urdf_joint_limits


def available_models(directory: Path = ROBOTS_DIR) -> list[str]:
    return sorted(p.stem for p in directory.glob("*.yaml"))


def find_robot_info(model_or_path: str, directory: Path = ROBOTS_DIR) -> Path:
    path = Path(model_or_path)
    if path.suffix in (".yaml", ".yml"):
        if not path.is_file():
            raise NotFound(f"robot info file not found: {path}")
        return path
    candidate = directory / f"{model_or_path}.yaml"
    if not candidate.is_file():
        known = ", ".join(available_models(directory)) or "none"
        raise NotFound(f"unknown robot model {model_or_path!r} (known: {known})")
    return candidate


def load_robot_info(model_or_path: str, directory: Path = ROBOTS_DIR) -> RobotInfo:
    """Load and validate a robot-info YAML. Joint position and velocity limits that the
    file leaves out are taken from the URDF; acceleration limits must be given. A file with
    `dh` (DH parameters) instead of a `urdf` gets a URDF made from them (dh_urdf.py), and
    then must give every joint's limits itself."""
    path = find_robot_info(model_or_path, directory)
    try:
        raw: Any = load_yaml(path.read_text())
    except yaml.YAMLError as exc:
        raise InvalidValue(f"{path.name}: not valid YAML: {exc}") from exc
    if not isinstance(raw, dict):
        raise InvalidValue(f"{path.name}: expected a mapping at the top level")
    joints = raw.get("joints")
    if not isinstance(joints, list) or not all(isinstance(j, dict) for j in joints):
        raise InvalidValue(f"{path.name}: 'joints' must be a list of mappings")
    if "dh" in raw:
        raw["urdf"] = _urdf_from_dh(path.name, raw, joints)
    uri = str(raw.get("urdf", ""))
    urdf = resolve_package_uri(uri, relative_to=path.parent)
    if not uri.startswith("package://"):
        raw["urdf"] = str(urdf)
    names = [str(j.get("name", "")) for j in joints]
    model, order = load_urdf_model(urdf, names)
    for joint, (lower, upper, velocity) in zip(
        joints, urdf_joint_limits(model, order), strict=True
    ):
        joint.setdefault("lower", lower)
        joint.setdefault("upper", upper)
        joint.setdefault("max_velocity", velocity)
    try:
        return RobotInfo.model_validate(raw)
    except ValueError as exc:
        raise InvalidValue(f"{path.name}: {exc}") from exc


def _urdf_from_dh(filename: str, raw: dict[str, Any], joints: list[dict[str, Any]]) -> str:
    if "urdf" in raw:
        raise InvalidValue(f"{filename}: give either 'urdf' or 'dh', not both")
    try:
        arm = DHArm.model_validate(raw.pop("dh"))
        limits = [(float(j["lower"]), float(j["upper"]), float(j["max_velocity"])) for j in joints]
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidValue(
            f"{filename}: 'dh' needs base_radius and links, and every "
            f"joint its lower, upper and max_velocity: {exc}"
        ) from exc
    if [link.joint for link in arm.links] != [str(j.get("name")) for j in joints]:
        raise InvalidValue(f"{filename}: the DH links' joints must be the joints, in order")
    links = (str(raw.get("base_link", "")), str(raw.get("flange_link", "")))
    if not all(links):
        raise InvalidValue(f"{filename}: 'dh' needs base_link and flange_link")
    model = str(raw.get("model", Path(filename).stem))
    return write_generated(model, dh_urdf(model, arm, links, limits))
