"""The runtime and its robot on two hosts: network namespaces this test makes, joined by veth
pairs (a runtime computer, a driver board, and a third host for an impostor). The link
between them is cut and restored while the robot moves.

A link drop during a held jog halts it and tells the client within 0.5 s, and the robot
does not move when the link returns, though the operator still holds the button; a drop
during a planned move ends it failed; the runtime reconnects within 1 s of the link's
return. An impostor announcing the robot's uuid from another host is shown, not followed,
and STOP still stops the real robot; so is one that passes the pairing challenge on to the
real robot while the robot's cable is out (issue 31), and a STOP after the link was moved to
it reaches the real robot too. Robots whose announcements lapsed during a 9 s outage are
listed again within 2 s of the link's return."""

from __future__ import annotations

import contextlib
import json
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

from openpendant.runtime.bench.harness.jog import JogClient
from openpendant.runtime.bench.harness.processes import (
    STILL,
    Proc,
    Runtime,
    SimRobotProc,
    child_env,
    wait_for,
)
from openpendant.runtime.kit.device_auth import proof
from tests.support import netns
from tests.support.netns import Link, Network, inside

WHY_NOT = netns.available()
pytestmark = [
    pytest.mark.integration,
    pytest.mark.skipif(WHY_NOT is not None, reason=f"no network namespaces: {WHY_NOT}"),
]
LINK_FAULTS = ("link_stale", "link_changed", "device_disconnected")
FAR = [2.5, -1.0, 1.2, -1.5, -1.57, 1.0]


def discovery_on(*addresses: str) -> dict[str, str]:
    return {"OPENPENDANT_DISCOVERY__INTERFACES": json.dumps(list(addresses))}


class HostRuntime(Runtime):
    """The runtime in its own namespace: the test reaches it from inside."""

    namespace = ""

    def api(
        self, method: str, path: str, role: str | None = "admin", **kwargs: Any
    ) -> httpx.Response:
        with inside(self.namespace):
            return super().api(method, path, role, **kwargs)


class BoardRobot:
    """The simulated robot as its own board sees it, however the network between is."""

    def __init__(self, namespace: str, url: str) -> None:
        self.namespace = namespace
        self.url = url

    def get(self, path: str, **params: Any) -> Any:
        with inside(self.namespace):
            return httpx.get(self.url + path, params=params, timeout=5).json()

    def post(self, path: str, body: Any) -> Any:
        with inside(self.namespace):
            return httpx.post(self.url + path, json=body, timeout=5)

    def q(self) -> np.ndarray[Any, Any]:
        return np.array(self.get("/state")["joint_position"])

    def moving(self) -> bool:
        return bool(np.abs(self.get("/state")["joint_velocity"]).max() > 0.02)

    def stopped(self) -> bool:
        return bool(np.allclose(self.get("/state")["joint_velocity"], 0.0))

    def commands(self, after: int = 0) -> list[dict[str, Any]]:
        found: list[dict[str, Any]] = self.get("/command_log", after=after)
        return found

    def last_seq(self) -> int:
        log = self.commands()
        return int(log[-1]["seq"]) if log else 0


class RelayProc(Proc):
    """tests/support/relay_impostor.py: announces the robot from another host and passes
    what it is asked to read, the pairing challenge included, on to the real robot."""

    def __init__(self, home: Path, host: str, upstream: str) -> None:
        argv = [sys.executable, "-m", "tests.support.relay_impostor", host, upstream]
        env = child_env(home, **discovery_on(host))
        super().__init__(argv, env, home / "logs" / f"relay-{host}.log")
        self.url = ""

    def wait_ready(self, timeout: float = 30.0) -> None:
        line = self.wait_line(lambda s: s.startswith('{"event": "ready"'), timeout)
        self.url = json.loads(line)["url"]


class Hosts:
    def __init__(self, home: Path) -> None:
        self.net = Network()
        self.runtime_host = self.net.namespace("rt")
        self.board_host = self.net.namespace("bd")
        self.other_host = self.net.namespace("im")
        self.wire: Link = self.net.link(self.runtime_host, self.board_host)
        self.other_wire: Link = self.net.link(self.runtime_host, self.other_host)
        self.home = home
        env = child_env(home, **discovery_on(self.wire.left_ip, self.other_wire.left_ip))
        with inside(self.runtime_host):
            self.runtime = HostRuntime(home / "rt", extra=["--no-sim"], env=env)
        self.runtime.namespace = self.runtime_host
        self.runtime.wait_ready()
        self.sim = self.start_robot(self.board_host, self.wire)
        self.robot = BoardRobot(self.board_host, self.sim.url)
        self.token = ""

    def start_robot(
        self,
        host: str,
        wire: Link,
        uuid: str | None = None,
        name: str = "board-ur5",
        env: dict[str, str] | None = None,
    ) -> SimRobotProc:
        extra = ["--host", wire.right_ip, *(["--uuid", uuid] if uuid else [])]
        home = self.home / (host if name == "board-ur5" else f"{host}-{name}")
        with inside(host):
            sim = SimRobotProc(
                home, name, extra=extra, env={**discovery_on(wire.right_ip), **(env or {})}
            )
        sim.wait_ready()
        return sim

    def add_robot(self) -> None:
        api = self.runtime.api
        wait_for(lambda: self.runtime.is_detected(self.sim.uuid), 10, what="robot detected")
        pairing = {"uuid": self.sim.uuid, "local_name": "robot", "pairing": self.sim.secret}
        added = api("POST", "/devices", json=pairing)
        assert added.status_code == 201, added.text
        self.wait_connected(10)
        self.token = api("POST", "/devices/robot/lease", json={"holder": "tests"}).json()["token"]

    def link_status(self, local_name: str = "robot") -> str:
        return str(self.runtime.api("GET", f"/devices/{local_name}").json()["status"])

    def listed(self) -> set[str]:
        return {d["uuid"] for d in self.runtime.api("GET", "/devices/detected").json()}

    def add_by_uuid(self, sim: SimRobotProc, local_name: str) -> None:
        pairing = {"uuid": sim.uuid, "local_name": local_name, "pairing": sim.secret}
        added = self.runtime.api("POST", "/devices", json=pairing)
        assert added.status_code == 201, added.text
        wait_for(
            lambda: self.link_status(local_name) == "connected", 10, what=f"{local_name}'s link"
        )

    def wait_connected(self, timeout: float) -> None:
        wait_for(lambda: self.link_status() == "connected", timeout, what="the robot's link")

    def ready(self) -> None:
        self.wait_connected(10)
        headers = {"X-Lease-Token": self.token}
        self.token = self.runtime.api(
            "POST", "/devices/robot/lease", json={"holder": "tests"}, headers=headers
        ).json()["token"]
        headers = {"X-Lease-Token": self.token}
        for command in ("reset_errors", "enable"):
            done = self.runtime.api("POST", f"/jog/robots/robot/{command}", headers=headers)
            assert done.status_code == 200, done.text
        wait_for(self.robot.stopped, 5, what="robot at rest")

    def device(self) -> dict[str, Any]:
        found: dict[str, Any] = self.runtime.api("GET", "/devices/robot").json()
        return found

    def halt_through_jog(self) -> None:
        """The pendant's STOP for the robot (any client may send it)."""
        stopped = self.runtime.api("POST", "/jog/robots/robot/halt")
        assert stopped.status_code == 200, stopped.text

    @contextlib.contextmanager
    def relaying_impostor(self) -> Iterator[RelayProc]:
        """The impostor of issue 31 on the other segment, with a way of its own to the
        robot's board (a third wire, and a route over it to the board's address)."""
        side = self.net.link(self.other_host, self.board_host)
        board_ip = f"{self.wire.right_ip}/32"
        netns.ip("-n", self.other_host, "route", "add", board_ip, "via", side.right_ip)
        real_url = self.device()["url"]
        with inside(self.other_host):
            relay = RelayProc(self.home / "relay", self.other_wire.right_ip, real_url)
        try:
            relay.wait_ready()
            yield relay
        finally:
            relay.stop()
            netns.ip("-n", self.other_host, "link", "del", side.left_if)

    def told(self, relay: RelayProc) -> list[dict[str, Any]]:
        """What the impostor was told to do."""
        with inside(self.other_host):
            found: list[dict[str, Any]] = httpx.get(f"{relay.url}/impostor/commands").json()
        return found

    def jog_client(self) -> JogClient:
        with inside(self.runtime_host):
            return JogClient(self.runtime, token=self.token)

    def close(self) -> None:
        self.sim.stop()
        self.runtime.stop()
        self.net.close()


@pytest.fixture(scope="module")
def hosts(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Hosts]:
    made = Hosts(tmp_path_factory.mktemp("netns"))
    try:
        made.add_robot()
        yield made
    finally:
        made.close()


def ended(jog: JogClient, press: str) -> dict[str, Any] | None:
    return next(
        (m for m in jog.messages if m.get("press") == press and m.get("state") != "moving"),
        None,
    )


def test_a_link_drop_during_a_held_jog_halts_it_and_nothing_resumes(hosts: Hosts) -> None:
    hosts.ready()
    jog = hosts.jog_client()
    try:
        press = jog.press(kind="joint", axis=0, direction=1, speed=0.3)
        # The operator holds the button through the whole outage: the heartbeats go on from
        # their own thread, whatever this test's steps (a subprocess to cut the wire, HTTP
        # into the board's namespace) cost on a loaded host.
        with jog.held(press):
            jog.drain(0.6)
            assert hosts.robot.moving()
            seq_before = hosts.robot.last_seq()
            dropped = time.monotonic()
            hosts.wire.down()
            try:
                while ended(jog, press) is None and time.monotonic() - dropped < 2.0:
                    jog.drain(0.01)
                told = time.monotonic() - dropped
                status = ended(jog, press)
                assert status is not None and status["state"] == "halted", status
                assert status["reason"] in LINK_FAULTS, status
                assert told < 0.5, f"the client heard of the lost link after {told:.2f} s"
                print(f"link dropped: the client was told after {told * 1000:.0f} ms")
                assert hosts.link_status() in ("stale", "disconnected")
                # The board halted the robot by itself: the runtime's session went silent. The
                # arm can be still before that (its last jog command expires first), so the
                # halt is waited for, not read once.
                wait_for(hosts.robot.stopped, 2, what="the robot halted on its board")
                halt = wait_for(
                    lambda: next(
                        (c for c in hosts.robot.commands(seq_before) if c["type"] == "halt"), None
                    ),
                    2,
                    what="the board's own halt",
                )
                assert halt["tag"] in ("session silent", "command stream closed"), halt
                jog.drain(max(0.0, 5.0 - (time.monotonic() - dropped)))  # a 5 s outage
                at_rest = hosts.robot.q()
                seq = hosts.robot.last_seq()
            finally:
                hosts.wire.up()
            returned = time.monotonic()
            hosts.wait_connected(1.5)
            reconnected = time.monotonic() - returned
            assert reconnected < 1.0, f"the runtime reconnected {reconnected:.2f} s after"
            print(f"link back: reconnected after {reconnected * 1000:.0f} ms")
            jog.drain(1.5)
        assert np.abs(hosts.robot.q() - at_rest).max() < STILL
        moved = [c for c in hosts.robot.commands(seq) if c["type"] not in ("halt", "command_mode")]
        assert moved == [], f"commands reached the robot after the link returned: {moved}"
    finally:
        jog.close()


def test_a_link_drop_during_a_planned_move_ends_it_failed(hosts: Hosts) -> None:
    hosts.ready()
    request = {"kind": "joint", "target": {"joints": FAR}, "speed": 0.1, "acceleration": 0.5}
    headers = {"X-Lease-Token": hosts.token}
    started = hosts.runtime.api("POST", "/motion/robots/robot/moves", json=request, headers=headers)
    assert started.status_code == 202, started.text
    move = started.json()["id"]
    wait_for(hosts.robot.moving, 10, what="the move running")
    hosts.wire.down()
    try:
        status = wait_for(
            lambda: (
                (s := hosts.runtime.api("GET", f"/motion/moves/{move}").json())["state"]
                not in ("planning", "running")
                and s
            ),
            3,
            what="the move to end",
        )
        assert status["state"] == "failed"
        assert status["code"] in LINK_FAULTS
        wait_for(hosts.robot.stopped, 2, what="the robot halted on its board")
        at_rest = hosts.robot.q()
        assert np.abs(at_rest - np.array(FAR)).max() > 0.1  # it did not run on to the end
    finally:
        hosts.wire.up()
    hosts.wait_connected(1.5)
    time.sleep(1.0)
    assert np.abs(hosts.robot.q() - at_rest).max() < STILL
    assert hosts.runtime.api("GET", f"/motion/moves/{move}").json()["state"] == "failed"


def test_an_impostor_is_shown_not_followed_and_stop_still_stops_the_real_robot(
    hosts: Hosts,
) -> None:
    hosts.ready()
    request = {"kind": "joint", "target": {"joints": FAR}, "speed": 0.1, "acceleration": 0.5}
    headers = {"X-Lease-Token": hosts.token}
    started = hosts.runtime.api("POST", "/motion/robots/robot/moves", json=request, headers=headers)
    assert started.status_code == 202, started.text
    wait_for(hosts.robot.moving, 10, what="the move running")
    real_url = hosts.runtime.api("GET", "/devices/robot").json()["url"]
    impostor = hosts.start_robot(hosts.other_host, hosts.other_wire, uuid=hosts.sim.uuid)
    try:
        claim = wait_for(
            lambda: hosts.runtime.api("GET", "/devices/robot").json()["address_claim"],
            5,
            what="the announcement from the other host shown",
        )
        assert claim["url"] == impostor.url and not claim["followed"]
        device = hosts.runtime.api("GET", "/devices/robot").json()
        assert device["url"] == real_url and device["status"] == "connected"
        assert hosts.robot.moving()  # nothing was halted or moved by the announcement
        jog = hosts.jog_client()
        try:
            seq = hosts.robot.last_seq()
            jog.send({"type": "halt", "robot": "robot"})
            stopped = hosts.runtime.api("POST", "/jog/robots/robot/halt")
            assert stopped.status_code == 200, stopped.text
        finally:
            jog.close()
        wait_for(hosts.robot.stopped, 2, what="the real robot halted")
        assert any(c["type"] == "halt" for c in hosts.robot.commands(seq))
        assert np.abs(hosts.robot.q() - np.array(FAR)).max() > 0.1
        impostor_robot = BoardRobot(hosts.other_host, impostor.url)
        assert impostor_robot.commands() == []  # the impostor heard nothing
    finally:
        impostor.stop()


def test_a_relayed_pairing_proof_is_not_followed_and_stop_halts_the_real_robot(
    hosts: Hosts,
) -> None:
    """Issue 31: the robot's cable out for a few seconds, an impostor on the other segment
    announced its uuid and passed the device manager's challenge on to the real board; the
    link moved to the impostor for good, and STOP went there. The board's proof covers its
    own address: the link stays, and STOP halts the real robot."""
    hosts.ready()
    real_url = hosts.device()["url"]
    before = hosts.device()["address_claim"]
    hosts.wire.down()  # the robot's cable out
    try:
        wait_for(lambda: hosts.link_status() != "connected", 2, what="the link lost")
        with hosts.relaying_impostor() as impostor:
            # The impostor really passes the challenge on: what it answers is the board's
            # own proof, of the board's own address.
            nonce = "issue-31-challenge"
            with inside(hosts.runtime_host):
                answer = httpx.get(f"{impostor.url}/pair/proof", params={"nonce": nonce}).json()
            assert answer["address"] == real_url.removeprefix("http://")
            assert answer["proof"] == proof(hosts.sim.secret, nonce, answer["address"])
            claim = wait_for(
                lambda: (c := hosts.device()["address_claim"]) != before and c,
                10,
                what="the impostor's announcement dealt with",
            )
            assert claim["url"] == impostor.url, claim
            assert not claim["followed"] and not claim["proven"], claim
            assert hosts.device()["url"] == real_url
            hosts.wire.up()
            hosts.wait_connected(5)
            device = hosts.device()
            assert device["url"] == real_url and device["address_claim"] == claim
            # STOP, with the impostor still there: the real robot halts, the impostor hears
            # nothing.
            hosts.ready()
            request = {"kind": "joint", "target": {"joints": FAR}, "speed": 0.1}
            headers = {"X-Lease-Token": hosts.token}
            started = hosts.runtime.api(
                "POST", "/motion/robots/robot/moves", json=request, headers=headers
            )
            assert started.status_code == 202, started.text
            wait_for(hosts.robot.moving, 10, what="the move running")
            seq = hosts.robot.last_seq()
            hosts.halt_through_jog()
            wait_for(hosts.robot.stopped, 2, what="the real robot halted")
            assert any(c["type"] == "halt" for c in hosts.robot.commands(seq))
            assert np.abs(hosts.robot.q() - np.array(FAR)).max() > 0.1
            assert hosts.told(impostor) == []
    finally:
        hosts.wire.up()
    hosts.wait_connected(5)


def test_a_stop_reaches_the_address_the_link_left_within_the_last_minute(hosts: Hosts) -> None:
    """Moved to the impostor by the user (its relayed answers made it look like the robot),
    the link's STOP still reaches the real robot: a STOP goes to every address the link used
    in the last minute."""
    hosts.ready()
    real_url = hosts.device()["url"]
    with hosts.relaying_impostor() as impostor:
        try:
            moved = hosts.runtime.api("PUT", "/devices/robot/address", json={"url": impostor.url})
            assert moved.status_code == 200, moved.text
            wait_for(
                lambda: (d := hosts.device())["status"] == "connected" and d["url"] == impostor.url,
                5,
                what="the link at the impostor",
            )
            seq = hosts.robot.last_seq()
            hosts.halt_through_jog()
            wait_for(
                lambda: any(c["type"] == "halt" for c in hosts.robot.commands(seq)),
                5,
                what="the halt at the real robot",
            )
            assert any(c["type"] == "halt" for c in hosts.told(impostor))
        finally:
            back = hosts.runtime.api("PUT", "/devices/robot/address", json={"url": real_url})
            assert back.status_code == 200, back.text
            hosts.wait_connected(5)
    assert hosts.device()["url"] == real_url


def test_robots_whose_records_lapsed_in_a_9_s_outage_are_listed_within_2_s_of_its_end(
    hosts: Hosts,
) -> None:
    """Issue 31: a record whose confirmations were lost in an outage was deleted and never
    asked for again (zeroconf keeps the pointer and reports nothing new): the live robot
    stayed off the list, and one removed meanwhile could not be added again by its uuid.
    Their 3 s TTL makes sure the records lapse while the cable is out."""
    short_ttl = {"OPENPENDANT_DISCOVERY__TTL": "3"}
    board, wire = hosts.board_host, hosts.wire
    live = hosts.start_robot(board, wire, name="outage-ur5", env=short_ttl)
    removed = hosts.start_robot(board, wire, name="removed-ur5", env=short_ttl)
    both = {live.uuid, removed.uuid}
    try:
        wait_for(lambda: both <= hosts.listed(), 10, what="both robots detected")
        hosts.add_by_uuid(live, "outage")
        hosts.add_by_uuid(removed, "removed")
        cut = time.monotonic()
        wire.down()
        try:
            wait_for(lambda: not both & hosts.listed(), 8, what="their records lapsed")
            assert hosts.runtime.api("DELETE", "/devices/removed").status_code == 200
            time.sleep(max(0.0, 9.0 - (time.monotonic() - cut)))  # the outage itself
        finally:
            # Taken before the link is set up: the deadline can only be stricter than
            # 2 s from the moment the link is back.
            returned = time.monotonic()
            wire.up()
        while True:
            listed = both <= hosts.listed()
            seen = time.monotonic() - returned
            if listed or seen >= 2.0:
                break
            time.sleep(0.02)
        assert listed, f"not listed again 2 s after the link returned: {both - hosts.listed()}"
        assert seen < 2.0, f"listed again only {seen:.2f} s after the link returned"
        print(f"listed again {seen * 1000:.0f} ms after the link returned")
        wait_for(lambda: hosts.link_status("outage") == "connected", 5, what="outage's link")
        # Confirmed as before: listed past a few of its TTLs while its link is up.
        for _ in range(20):
            time.sleep(0.3)
            assert live.uuid in hosts.listed()
        hosts.add_by_uuid(removed, "removed")  # added again by its uuid after the outage
    finally:
        for local_name in ("outage", "removed"):
            hosts.runtime.api("DELETE", f"/devices/{local_name}")
        live.stop()
        removed.stop()


def test_a_network_that_appears_after_start_is_listened_on(tmp_path: Path) -> None:
    """Discovery on every interface follows interfaces that come up later (a cable plugged
    in): a robot on a network made after the runtime started is detected."""
    net = Network()
    try:
        runtime_host = net.namespace("rt")
        board_host = net.namespace("bd")
        env = child_env(tmp_path, OPENPENDANT_DISCOVERY__INTERFACES='"all"')
        with inside(runtime_host):
            runtime = HostRuntime(tmp_path / "rt", extra=["--no-sim"], env=env)
        runtime.namespace = runtime_host
        runtime.wait_ready()
        try:
            wire = net.link(runtime_host, board_host)  # plugged in after start
            with inside(board_host):
                sim = SimRobotProc(
                    tmp_path / "bd",
                    "late-ur5",
                    extra=["--host", wire.right_ip],
                    env=discovery_on(wire.right_ip),
                )
            sim.wait_ready()
            try:
                wait_for(lambda: runtime.is_detected(sim.uuid), 12, what="detected")
            finally:
                sim.stop()
        finally:
            runtime.stop()
    finally:
        net.close()
