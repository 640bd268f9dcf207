"""The simulated cell's world: which part a closing gripper takes, how a held part follows
the TCP, where it lands when let go, and what the presence sensors see; and the socket the
simulated devices ask it over."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from scipy.spatial.transform import Rotation

from openpendant.device_drivers.sim_cell.link import CellClient, CellServer, address
from openpendant.device_drivers.sim_cell.world import CellSetup, FlangeTag, Part, Sensor, World
from openpendant.runtime.interfaces.common import Pose

QUARTER_TURN = [0.0, 0.0, 0.7071068, 0.7071068]  # 90° about z


def setup() -> CellSetup:
    return CellSetup(
        parts=[
            Part(id="near", size=[0.04, 0.04, 0.04], pose=Pose(position=[0.5, 0.0, 0.02])),
            Part(id="wide", size=[0.2, 0.2, 0.04], pose=Pose(position=[0.505, 0.0, 0.03])),
            Part(id="far", size=[0.04, 0.04, 0.04], pose=Pose(position=[0.5, 0.1, 0.02])),
        ],
        sensors={"at_pick": Sensor(position=[0.5, 0.0, 0.02], radius=0.005)},
    )


def test_a_closing_gripper_takes_the_nearest_part_that_fits_and_carries_it() -> None:
    tcp = Pose(position=[0.505, 0.0, 0.03])
    world = World(lambda: tcp, setup())
    assert world.sensed() == {"at_pick": True}
    assert world.grasp(opening=0.01) is None  # nothing fits between 10 mm fingers
    held = world.grasp(opening=0.085)
    assert held is not None and held.id == "near"  # "wide" is nearer, but too wide
    assert world.sensed() == {"at_pick": False}  # in the gripper, not on the table
    tcp = Pose(position=[0.2, -0.3, 0.4], orientation=QUARTER_TURN)
    carried = next(p for p in world.snapshot() if p.id == "near")
    assert carried.held
    # The part keeps its offset from the TCP (5 mm along the TCP's x, turned with it).
    assert carried.pose.position == pytest.approx([0.2, -0.305, 0.39], abs=1e-6)
    fallen = world.release()
    assert fallen is not None and fallen.pose.position == pytest.approx([0.2, -0.305, 0.02])
    assert fallen.pose.orientation == pytest.approx(QUARTER_TURN, abs=1e-6)  # upright, turned
    assert world.release() is None  # nothing held any more
    assert not any(p.held for p in world.snapshot())


def test_out_of_reach_nothing_is_taken() -> None:
    world = World(lambda: Pose(position=[0.5, 0.0, 0.2]), setup())
    assert world.grasp(opening=0.085) is None


def test_the_devices_ask_the_world_over_its_socket(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    monkeypatch.delenv("OPENPENDANT_SETTINGS_JSON", raising=False)
    world = World(lambda: Pose(position=[0.5, 0.0, 0.02]), setup())

    async def main() -> None:
        server = CellServer(world, "arm")
        await server.start()
        try:
            client = CellClient("arm")
            assert (await client.ask("sensed")) == {"sensors": {"at_pick": True}}
            taken = await client.ask("grasp", opening=0.05)
            assert taken is not None and taken["part"]["id"] == "near"
            assert (await client.ask("nonsense"))["error"]  # type: ignore[index]
            assert await CellClient("another-arm").ask("sensed") is None  # no such world
        finally:
            await server.stop()

    asyncio.run(main())
    assert address("arm", tmp_path) != address("arm", tmp_path / "elsewhere")


def test_a_robot_set_down_elsewhere_leaves_the_parts_where_they_are_in_the_world() -> None:
    tcp = Pose(position=[0.505, 0.0, 0.03])
    flange = Pose(position=[0.505, 0.0, 0.13], orientation=[1.0, 0.0, 0.0, 0.0])  # z down
    world = World(
        lambda: tcp, setup().model_copy(update={"flange_tag": FlangeTag()}), flange=lambda: flange
    )
    world.move_base(Pose(position=[0.0, 0.1, 0.0]))
    near = next(p for p in world.snapshot("world") if p.id == "near")
    assert near.pose.position == pytest.approx([0.5, 0.0, 0.02])  # laid out before the move
    in_base = next(p for p in world.snapshot() if p.id == "near")
    assert in_base.pose.position == pytest.approx([0.5, -0.1, 0.02])
    # The TCP is 10 cm from "near" now, but "far" is under it: that one is taken.
    held = world.grasp(opening=0.085)
    assert held is not None and held.id == "far"
    scene = world.scene()
    assert scene["base"]["position"] == pytest.approx([0.0, 0.1, 0.0])
    tag = scene["flange_tag"]
    # The tag's print faces along the flange's z (down here): its into-print z points up.
    assert tag["pose"]["position"] == pytest.approx([0.505, 0.1, 0.125])
    into_print = Rotation.from_quat(tag["pose"]["orientation"]).apply([0.0, 0.0, 1.0])
    assert into_print == pytest.approx([0.0, 0.0, 1.0], abs=1e-9)
    assert world.sensed() == {"at_pick": True}  # the sensor stays by the table, as its part
