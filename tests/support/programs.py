"""A pick-and-place Blockly program for the simulated UR5, and the waypoints it visits."""

from __future__ import annotations

from typing import Any

from openpendant.runtime.bench.harness.blocks import (
    block,
    number,
    stack,
    text,
    var,
    waypoint,
    workspace,
)
from openpendant.runtime.bench.harness.processes import Runtime
from openpendant.runtime.robotics.robot_info import load_robot_info

HOME = load_robot_info("ur5").home
ABOVE_PICK = [0.6, -1.3, 1.6, -1.87, -1.57, 0.0]
PICK = [0.6, -1.15, 1.75, -2.17, -1.57, 0.0]
ABOVE_PLACE = [-0.6, -1.3, 1.6, -1.87, -1.57, 0.0]
PLACE = [-0.6, -1.15, 1.75, -2.17, -1.57, 0.0]
PICK_AND_PLACE_WAYPOINTS = {
    "above_pick": ABOVE_PICK,
    "pick": PICK,
    "above_place": ABOVE_PLACE,
    "place": PLACE,
}


def teach(runtime: Runtime, waypoints: dict[str, list[float]], robot: str = "robot") -> None:
    """Stores joint waypoints, as teaching them on the Jog panel would."""
    for name, joints in waypoints.items():
        stored = runtime.api(
            "PUT",
            f"/variables/{name}",
            json={"type": "joint_waypoint", "value": {"joints": joints, "robot": robot}},
        )
        assert stored.status_code == 200, stored.text


def pick_and_place() -> tuple[dict[str, Any], dict[str, Any]]:
    pairs = block("lists_create_with", None, ADD0=text("pick"), ADD1=text("place"))
    pairs["extraState"] = {"itemCount": 2}
    body = stack(
        block(
            "controls_if",
            IF0=block("logic_compare", {"OP": "EQ"}, A=var("spot"), B=text("pick")),
            DO0=stack(
                block("robot_move_joint", TARGET=waypoint("above_pick")),
                block("robot_move_linear", TARGET=waypoint("pick")),
                block("robot_tool", {"ACTION": "CLOSE"}),
                block(
                    "io_set_output",
                    {"NAME": "robot.do1"},
                    VALUE=block("logic_boolean", {"BOOL": "TRUE"}),
                ),
                block("robot_move_linear", TARGET=waypoint("above_pick")),
            ),
            ELSE=stack(
                block("robot_move_joint", TARGET=waypoint("above_place")),
                block("robot_move_linear", TARGET=waypoint("place")),
                block("robot_tool", {"ACTION": "OPEN"}),
                block(
                    "robot_move_relative", {"FRAME": "base"}, X=number(0), Y=number(0), Z=number(40)
                ),
            ),
        ),
        block("time_wait", SECONDS=number(0.2)),
        block("text_print", TEXT=block("text_join", None, ADD0=text("done "), ADD1=var("spot"))),
    )
    body["extraState"] = {"hasElse": True}
    main = stack(
        block("robot_use", {"ROBOT": "robot"}),
        block("robot_set_speed", SPEED=number(100)),
        block("robot_tool", {"ACTION": "OPEN"}),
        block("controls_forEach", {"VAR": {"id": "spot"}}, LIST=pairs, DO=body),
        block("program_log", {"LEVEL": "info"}, TEXT=text("cycle complete")),
    )
    return workspace(main, variables=("spot",)), main
