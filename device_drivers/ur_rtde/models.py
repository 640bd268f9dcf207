"""Is the controller the arm the driver's robot-info file describes? A UR5e driven with a
UR5's kinematics and limits moves where nobody meant it to, so the driver asks the
dashboard (`get robot model`: UR3, UR5, UR10, UR16, UR20, UR30; `PolyscopeVersion`: 3.x on
a CB3, 5.x and later on an e-Series) before it takes the arm over."""

from __future__ import annotations

import re

CB3 = frozenset({"ur3", "ur5", "ur10"})
_UR_MODEL = re.compile(r"ur(\d+)e?", re.IGNORECASE)
_VERSION = re.compile(r"(\d+)\.\d+")


def generation(polyscope: str) -> str | None:
    """ "CB3" or "e-Series" from the dashboard's PolyscopeVersion answer."""
    found = _VERSION.search(polyscope)
    if found is None:
        return None
    major = int(found[1])
    return "CB3" if major == 3 else "e-Series" if major >= 5 else None


def model_mismatch(model: str, reported_model: str, polyscope: str) -> str | None:
    """Why a controller that reports `reported_model` and `polyscope` is not the `model` of
    the robot-info file, or None when it is. A file of one's own whose model is not a UR
    name (`ur5e`, `ur10`, …) is taken on its author's word."""
    if _UR_MODEL.fullmatch(model.strip()) is None:
        return None
    wanted = model.strip().lower()
    family = re.sub(r"e$", "", wanted).upper()
    wanted_generation = "CB3" if wanted in CB3 else "e-Series"
    says, its_generation = reported_model.strip().upper(), generation(polyscope)
    if says == family and its_generation == wanted_generation:
        return None
    arm = f"{says or 'an unknown arm'} ({its_generation or f'PolyScope {polyscope.strip()!r}'})"
    return (
        f"the controller is a {arm}, not a {wanted} ({wanted_generation}): start the driver "
        f"with the --model of this arm"
    )
