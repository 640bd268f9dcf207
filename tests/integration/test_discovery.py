"""Discovery and device identity under stress, on loopback: goodbyes and lost goodbyes, a
burst of 500 announcements, hostile announcements and /info answers, removing and
re-pointing an added device, whose each device is (added here, paired, another's)."""

from __future__ import annotations

import json
import secrets
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from websockets.sync.client import connect
from zeroconf import ServiceInfo, Zeroconf

from openpendant.runtime.bench.harness.processes import (
    Proc,
    Runtime,
    SimRobotProc,
    child_env,
    stop_all,
    wait_for,
)
from openpendant.runtime.kit.discovery import SERVICE_TYPE
from tests.support.fake_device import FakeDevice

SHORT_TTL = {"OPENPENDANT_DISCOVERY__TTL": "3"}


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    proc = Runtime(tmp_path_factory.mktemp("discovery"), extra=["--no-sim"])
    proc.wait_ready()
    try:
        yield proc
    finally:
        proc.stop()


def detected(runtime: Runtime) -> dict[str, dict[str, Any]]:
    return {d["uuid"]: d for d in runtime.api("GET", "/devices/detected").json()}


def rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


def manager_log(runtime: Runtime) -> str:
    return (runtime.data_dir / "logs" / "device_manager.log").read_text(errors="replace")


def test_a_driver_stopped_with_sigterm_leaves_the_list_within_2_s(
    runtime: Runtime, tmp_path: Path
) -> None:
    sim = SimRobotProc(tmp_path, "goodbye-ur5")
    sim.wait_ready()
    wait_for(lambda: sim.uuid in detected(runtime), 10, what="detected")
    stopped = time.monotonic()
    sim.stop()  # SIGTERM: the driver says goodbye
    wait_for(lambda: sim.uuid not in detected(runtime), 2.0, what="gone after its goodbye")
    print(f"gone {time.monotonic() - stopped:.2f} s after SIGTERM")


def test_a_driver_that_vanishes_without_goodbye_leaves_when_its_records_lapse(
    runtime: Runtime, tmp_path: Path
) -> None:
    sim = SimRobotProc(tmp_path, "vanish-ur5", env=SHORT_TTL)
    sim.wait_ready()
    wait_for(lambda: sim.uuid in detected(runtime), 10, what="detected")
    # Alive, it is asked to confirm itself and stays listed past its 3 s TTL (a refresh at
    # 80 % of it, 2.4 s, is needed by then).
    for _ in range(23):
        time.sleep(0.2)
        assert sim.uuid in detected(runtime)
    killed = time.monotonic()
    sim.kill()  # no goodbye at all
    wait_for(lambda: sim.uuid not in detected(runtime), 6.0, what="gone when its TTL ran out")
    print(f"gone {time.monotonic() - killed:.2f} s after kill -9 (TTL 3 s)")


def test_500_announcements_at_once_are_all_listed_and_all_goodbyes_heard(
    runtime: Runtime, tmp_path: Path
) -> None:
    burst = subprocess.Popen(
        [sys.executable, "-m", "tests.support.announce", "500"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=child_env(tmp_path),
    )
    assert burst.stdout is not None and burst.stdin is not None
    try:
        uuids = set(json.loads(burst.stdout.readline())["uuids"])
        assert len(uuids) == 500
        wait_for(lambda: uuids <= set(detected(runtime)), 10, what="all 500 listed")
    finally:
        burst.stdin.close()
        burst.wait(30)
    wait_for(lambda: not uuids & set(detected(runtime)), 10, what="all 500 goodbyes heard")


def announce(zc: Zeroconf, label: str, properties: dict[str, Any], port: int) -> ServiceInfo:
    info = ServiceInfo(
        SERVICE_TYPE,
        f"{label}.{SERVICE_TYPE}",
        addresses=[bytes([127, 0, 0, 1])],
        port=port,
        properties=properties,
        server=f"{label}.local.",
    )
    zc.register_service(info, cooperating_responders=True)
    return info


def test_malformed_and_oversized_announcements_are_refused_with_a_log_line(
    runtime: Runtime,
) -> None:
    zc = Zeroconf(interfaces=["127.0.0.1"])
    try:
        announce(zc, "long-uuid", {"uuid": "x" * 200, "kind": "robot"}, 30001)
        announce(zc, "control-uuid", {"uuid": "a\x1b[31m", "kind": "robot"}, 30002)
        announce(zc, "no-uuid", {"kind": "robot"}, 30003)
        announce(zc, "bad-kind", {"uuid": "toaster-1", "kind": "toaster"}, 30004)
        announce(
            zc,
            "hostile-name",
            {"uuid": "named-1", "kind": "robot", "name": "ro\u202ebot\u200b\n" + "n" * 200},
            30005,
        )
        found = wait_for(lambda: detected(runtime).get("named-1"), 10, what="the good one")
        assert found["name"] == "robot" + "n" * 59  # cleaned and capped at 64
        time.sleep(1.0)  # the others had as long
        listed = detected(runtime)
        assert "toaster-1" not in listed
        # Not cleaned and listed either (other runtimes on loopback list their own devices,
        # whose uuids may start with any hex digit).
        assert not [u for u in listed if u.startswith(("x" * 64, "a\x1b", "a[31m"))]
        log = manager_log(runtime)
        assert "ignoring announcement long-uuid" in log
        assert "ignoring announcement control-uuid" in log
    finally:
        zc.close()


def test_info_answers_too_big_or_malformed_are_refused_and_memory_stays_bounded(
    runtime: Runtime,
) -> None:
    pid = int(runtime.api("GET", "/health").json()["services"]["device_manager"]["pid"])
    before = rss_kib(pid)
    fake = FakeDevice()
    try:
        cases = {
            "huge uuid": json.dumps({"identity": {"uuid": "u" * 5_000_000, "kind": "robot"}}),
            "empty uuid": json.dumps({"identity": {"uuid": "", "kind": "robot"}}),
            "no identity": json.dumps({"identity": "robot"}),
            "not json": "<html>hello</html>",
            "a list": "[1, 2, 3]",
        }
        for case, body in cases.items():
            fake.info = body.encode()
            response = runtime.api("POST", "/devices", json={"url": fake.url, "local_name": "fake"})
            assert 400 <= response.status_code < 500, (case, response.status_code)
            error = response.json()["error"]
            assert error["code"] in ("device_unreachable", "device_invalid"), case
            assert len(response.content) < 2000, case
        assert runtime.api("GET", "/devices/fake").status_code == 404
        assert manager_log(runtime).count("refused to add the device at") >= len(cases)
    finally:
        fake.close()
    assert rss_kib(pid) - before < 50_000  # KiB: a 5 MB answer was never read whole


def test_a_removed_device_leaves_no_session_behind(runtime: Runtime, tmp_path: Path) -> None:
    sim = SimRobotProc(tmp_path, "removed-ur5")
    sim.wait_ready()
    try:
        wait_for(lambda: sim.uuid in detected(runtime), 10, what="detected")
        pairing = {"uuid": sim.uuid, "local_name": "gone", "pairing": sim.secret}
        added = runtime.api("POST", "/devices", json=pairing)
        assert added.status_code == 201, added.text
        wait_for(
            lambda: runtime.api("GET", "/devices/gone").json()["status"] == "connected",
            10,
            what="connected",
        )
        clients = httpx.get(f"{sim.url}/clients").json()
        assert clients["sessions"] == 1 and clients["state_streams"] >= 1
        assert runtime.api("DELETE", "/devices/gone").status_code == 200
        wait_for(
            lambda: (
                httpx.get(f"{sim.url}/clients").json()
                == {"state_streams": 0, "command_streams": 0, "sessions": 0}
            ),
            1.0,
            what="no session left at the driver",
        )
    finally:
        sim.stop()


def test_a_device_can_be_re_pointed_by_the_user_and_an_impostor_is_refused(
    runtime: Runtime, tmp_path: Path
) -> None:
    first = SimRobotProc(tmp_path, "moving-ur5")
    first.wait_ready()
    added = runtime.api(
        "POST",
        "/devices",
        json={"url": first.url, "local_name": "mover", "pairing": first.secret},
    )
    assert added.status_code == 201, added.text
    wait_for(lambda: runtime.api("GET", "/devices/mover").json()["status"] == "connected", 10)
    second = SimRobotProc(tmp_path, "moving-ur5", extra=["--uuid", first.uuid])
    other = SimRobotProc(tmp_path, "someone-else")
    try:
        second.wait_ready()
        other.wait_ready()
        refused = runtime.api("PUT", "/devices/mover/address", json={"url": other.url})
        assert refused.status_code == 409 and refused.json()["error"]["code"] == "wrong_device"
        moved = runtime.api("PUT", "/devices/mover/address", json={"url": second.url})
        assert moved.status_code == 200, moved.text
        wait_for(
            lambda: (
                (d := runtime.api("GET", "/devices/mover").json())["status"] == "connected"
                and d["url"] == second.url
            ),
            5,
            what="connected at the new address",
        )
        assert httpx.get(f"{first.url}/clients").json()["sessions"] == 0
        claim = runtime.api("GET", "/devices/mover").json()["address_claim"]
        assert claim["url"] == first.url and claim["followed"]
    finally:
        for proc in (first, second, other):
            proc.stop()
        runtime.api("DELETE", "/devices/mover")


def test_a_device_back_at_another_address_is_followed_only_if_it_proves_who_it_is(
    runtime: Runtime, tmp_path: Path
) -> None:
    """Issue 15: an announcement with an added robot's uuid took over its connection. Issue
    16: its goodbye took the genuine robot off the detected list."""
    board = tmp_path / "board"  # the robot's board keeps its pairing secret
    first = SimRobotProc(board, "returning-ur5")
    first.wait_ready()
    pairing = {"url": first.url, "local_name": "returning", "pairing": first.secret}
    assert runtime.api("POST", "/devices", json=pairing).status_code == 201
    wait_for(lambda: runtime.api("GET", "/devices/returning").json()["status"] == "connected", 10)
    first.stop()  # the link is down: where it comes back is where it will be commanded
    impostor = SimRobotProc(tmp_path / "elsewhere", "returning-ur5", extra=["--uuid", first.uuid])
    genuine: SimRobotProc | None = None
    try:
        impostor.wait_ready()
        claim = wait_for(
            lambda: (
                (c := runtime.api("GET", "/devices/returning").json()["address_claim"])
                and c["url"] == impostor.url
                and c
            ),
            10,
            what="the impostor's claim shown",
        )
        assert not claim["followed"]
        device = runtime.api("GET", "/devices/returning").json()
        assert device["url"] == first.url and device["status"] != "connected"
        genuine = SimRobotProc(board, "returning-ur5", extra=["--uuid", first.uuid])
        genuine.wait_ready()
        wait_for(
            lambda: (
                (d := runtime.api("GET", "/devices/returning").json())["status"] == "connected"
                and d["url"] == genuine.url
            ),
            10,
            what="the genuine robot followed to its new port",
        )
        assert httpx.get(f"{impostor.url}/clients").json()["sessions"] == 0

        # Both announce the uuid: the list shows the one the robot is linked at, and the
        # other address. The impostor's goodbye ends its own announcement only.
        def listed() -> dict[str, Any] | None:
            return detected(runtime).get(first.uuid)

        wait_for(
            lambda: (d := listed()) and d["url"] == genuine.url and d["also_at"] == [impostor.url],
            10,
            what="both announcements listed",
        )
        impostor.stop()
        wait_for(lambda: (d := listed()) and d["also_at"] == [], 5, what="the impostor's goodbye")
        listing = listed()
        assert listing is not None and listing["url"] == genuine.url
    finally:
        for proc in (impostor, genuine):
            if proc is not None:
                proc.stop()
        runtime.api("DELETE", "/devices/returning")


def test_the_list_marks_what_is_added_here_paired_with_this_runtime_or_another_s(
    runtime: Runtime, tmp_path: Path
) -> None:
    """Issue 32: a neighbouring runtime's simulated UR5 was listed exactly like this cell's,
    and a device announcing the uuid of one this runtime is paired with, without its key,
    like the device itself."""
    name = f"marked-{secrets.token_hex(3)}"  # others' tests on this loopback: a uuid of its own
    neighbour = Runtime(tmp_path / "neighbour")  # its own simulated UR5, started by it
    board = SimRobotProc(tmp_path / "board", name)  # started by hand: paired with nobody yet
    started: list[Proc] = [neighbour, board]

    def mark(where: Runtime, uuid: str) -> tuple[str, str | None] | None:
        listed = detected(where).get(uuid)
        return (listed["mark"], listed["elsewhere"]) if listed else None

    def marked(where: Runtime, uuid: str, wanted: tuple[str, str | None]) -> None:
        wait_for(lambda: mark(where, uuid) == wanted, 10, what=f"{uuid} marked {wanted}")

    try:
        neighbour.wait_ready()
        board.wait_ready()
        theirs = neighbour.own_device()["uuid"]
        marked(runtime, theirs, ("elsewhere", "other_runtime"))
        assert mark(neighbour, theirs) == ("paired", None)  # its own: it holds the key
        marked(runtime, board.uuid, ("new", None))
        marked(neighbour, board.uuid, ("new", None))

        pairing = {"url": board.url, "local_name": "marked", "pairing": board.secret}
        assert runtime.api("POST", "/devices", json=pairing).status_code == 201
        assert mark(runtime, board.uuid) == ("added", None)
        assert mark(neighbour, board.uuid) == ("new", None)
        assert runtime.api("DELETE", "/devices/marked").status_code == 200
        assert mark(runtime, board.uuid) == ("paired", None)  # its key is kept

        # The device a second time (its uuid and key) is announced under names of its own
        # (RFC 6762 §9); another device with its uuid, not its key, does not speak for it.
        twin = SimRobotProc(tmp_path / "board", name, extra=["--uuid", board.uuid])
        clone = SimRobotProc(tmp_path / "clone", name, extra=["--uuid", board.uuid])
        started += [twin, clone]
        twin.wait_ready()
        clone.wait_ready()
        everywhere = sorted([board.url, twin.url, clone.url])
        wait_for(
            lambda: (
                (d := detected(runtime).get(board.uuid))
                and sorted([d["url"], *d["also_at"]]) == everywhere
                and d
            ),
            10,
            what="three announcements of one uuid",
        )
        listed = detected(runtime)[board.uuid]
        assert listed["url"] in (board.url, twin.url) and listed["mark"] == "paired", listed
        board.stop()
        twin.stop()
        marked(runtime, board.uuid, ("elsewhere", "other_key"))
        assert detected(runtime)[board.uuid]["url"] == clone.url
    finally:
        stop_all(started)
        runtime.api("DELETE", "/devices/marked")


def test_malformed_link_socket_messages_are_refused_and_the_socket_stays(
    runtime: Runtime,
) -> None:
    """The device manager's link socket (for services) answers bad messages with a refusal
    and keeps serving."""
    base = runtime.api("GET", "/health").json()["services"]["device_manager"]["url"]
    link = base.replace("http://", "ws://") + "/devices/_links"
    with connect(link, additional_headers=runtime.internal()) as ws:
        bad = [
            "not json",
            "[1, 2]",
            json.dumps({"op": "teleport"}),
            json.dumps({"op": "send", "device": "nobody", "command": {"type": "halt"}}),
            json.dumps({"op": "claim", "device": "nobody", "gen": "x"}),
            json.dumps({"op": "call", "ref": 7, "device": "nobody", "gen": 1, "path": "x"}),
            json.dumps({"op": "send", "device": "nobody", "gen": 1, "command": {"type": "x"}}),
            # A body relayed as JSON text must be text.
            json.dumps(
                {"op": "call", "ref": 8, "device": "nobody", "gen": 1, "method": "GET"}
                | {"path": "/state", "body_text": 5}
            ),
        ]
        for message in bad:
            ws.send(message)
        refusals: list[dict[str, Any]] = []
        deadline = time.monotonic() + 5
        while len(refusals) < len(bad) - 1 and time.monotonic() < deadline:
            for line in str(ws.recv(timeout=5)).split("\n"):
                body = json.loads(line)
                if body.get("type") in ("refused", "reply"):
                    refusals.append(body)
        codes = [r.get("error", {}).get("code") or r["body"]["error"]["code"] for r in refusals]
        assert codes.count("bad_message") >= 4
        relayed = [r for r in refusals if r.get("ref") == 8]
        assert relayed and relayed[0]["body"]["error"]["code"] == "bad_message", relayed
        assert "device_not_found" in codes
        ws.send(json.dumps({"op": "watch", "devices": "*"}))  # still served
        ws.send(json.dumps({"op": "hello", "service": "tests"}))
