"""The variable storage as a process: REST, notifications, YAML, concurrency, crash safety."""

from __future__ import annotations

import json
import random
import sqlite3
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import yaml
from websockets.sync.client import connect

from openpendant.runtime.bench.harness.processes import Proc, child_env, free_port, wait_for
from tests.unit.test_variable_store import REJECT, ROUND_TRIP

# A store over HTTP holds no real-time margin: it runs beside the real-time tests.
pytestmark = pytest.mark.concurrent


class Storage(Proc):
    def __init__(self, home: Path, data_dir: Path, port: int | None = None) -> None:
        self.port = port or free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.data_dir = data_dir
        super().__init__(
            [
                sys.executable,
                "-m",
                "openpendant.runtime.cli",
                "service",
                "variable_storage",
                "--port",
                str(self.port),
                "--data-dir",
                str(data_dir),
            ],
            child_env(home),
            home / "logs" / f"storage-{self.port}.log",
        )
        wait_for(
            lambda: httpx.get(f"{self.url}/health", timeout=1).status_code == 200,
            30,
            what="variable storage up",
        )


@pytest.fixture
def storage(home: Path) -> Iterator[Storage]:
    proc = Storage(home, home / "data")
    yield proc
    proc.stop()


def put(
    client: httpx.Client, name: str, type_name: str, value: object, **extra: object
) -> httpx.Response:
    return client.put(f"/variables/{name}", json={"type": type_name, "value": value, **extra})


@pytest.mark.parametrize("type_name", sorted(ROUND_TRIP))
def test_every_type_round_trips_over_http(storage: Storage, type_name: str) -> None:
    with httpx.Client(base_url=storage.url) as client:
        stored = put(
            client,
            f"var_{type_name}",
            type_name,
            ROUND_TRIP[type_name],
            tags=["cell-1"],
            doc="taught on Monday",
        )
        assert stored.status_code == 200, stored.text
        got = client.get(f"/variables/var_{type_name}").json()
        assert got["value"] == ROUND_TRIP[type_name]
        assert (got["type"], got["tags"], got["doc"], got["version"]) == (
            type_name,
            ["cell-1"],
            "taught on Monday",
            1,
        )
        assert [v["name"] for v in client.get("/variables", params={"tag": "cell-1"}).json()] == [
            f"var_{type_name}"
        ]


def test_invalid_values_over_http_change_nothing(storage: Storage) -> None:
    with httpx.Client(base_url=storage.url) as client:
        assert put(client, "keep", "number", 1.0).status_code == 200
        for type_name, value in REJECT:
            # Python's json writes NaN and Infinity as the bare words JavaScript would send.
            raw = json.dumps({"type": type_name, "value": value})
            response = client.put(
                "/variables/keep", content=raw, headers={"content-type": "application/json"}
            )
            assert response.status_code in (409, 422), (type_name, value)
            assert "error" in response.json()
        for raw in (
            '{"type": "number", "value": NaN}',
            '{"type": "number", "value": Infinity}',
            '{"type": "json", "value": {"a": [1, -Infinity]}}',
            "{not json",
        ):
            response = client.put(
                "/variables/keep", content=raw, headers={"content-type": "application/json"}
            )
            assert response.status_code == 422
        kept = client.get("/variables/keep").json()
        assert (kept["value"], kept["version"]) == (1.0, 1)


def test_concurrent_writers_lose_no_update(storage: Storage) -> None:
    """Eight clients increment one counter with optimistic concurrency, while each also
    writes variables of its own: every increment and every write is there at the end."""
    with httpx.Client(base_url=storage.url) as client:
        put(client, "counter", "number", 0)
    increments, writers = 15, 8
    errors: list[str] = []

    def worker(k: int) -> None:
        with httpx.Client(base_url=storage.url, timeout=30) as client:
            done = 0
            while done < increments:
                current = client.get("/variables/counter").json()
                response = put(
                    client,
                    "counter",
                    "number",
                    current["value"] + 1,
                    expected_version=current["version"],
                )
                if response.status_code == 200:
                    done += 1
                    put(client, f"w{k}_{done}", "number", done)
                elif response.json()["error"]["code"] != "version_conflict":
                    errors.append(response.text)
                    return

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(writers)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    with httpx.Client(base_url=storage.url) as client:
        assert client.get("/variables/counter").json()["value"] == increments * writers
        names = {v["name"] for v in client.get("/variables").json()}
    assert {f"w{k}_{d}" for k in range(writers) for d in range(1, increments + 1)} <= names


def test_changes_are_notified_over_websocket(storage: Storage) -> None:
    ws_url = storage.url.replace("http", "ws") + "/variables/_events"
    with connect(ws_url) as ws, httpx.Client(base_url=storage.url) as client:
        time.sleep(0.1)
        put(client, "wp1", "joint_waypoint", ROUND_TRIP["joint_waypoint"])
        client.delete("/variables/wp1")
        changed = json.loads(ws.recv(timeout=5))
        deleted = json.loads(ws.recv(timeout=5))
    assert changed["type"] == "changed"
    assert changed["variable"]["name"] == "wp1"
    assert changed["variable"]["value"] == ROUND_TRIP["joint_waypoint"]
    assert deleted["type"] == "deleted"
    assert deleted["variable"]["name"] == "wp1"


def test_yaml_export_imports_into_a_fresh_storage(home: Path, storage: Storage) -> None:
    with httpx.Client(base_url=storage.url) as client:
        for type_name, value in ROUND_TRIP.items():
            put(client, f"x_{type_name}", type_name, value, tags=["export"], doc=type_name)
        exported = client.get("/variables/_export")
        assert exported.headers["content-type"].startswith("application/yaml")
        original = client.get("/variables").json()
    document = yaml.safe_load(exported.text)
    assert len(document["variables"]) == len(ROUND_TRIP)
    fresh = Storage(home, home / "fresh")
    try:
        with httpx.Client(base_url=fresh.url) as client:
            bad = exported.text.replace("value: 12.5", "value: .nan")
            refused = client.post("/variables/_import", content=bad)
            assert refused.status_code == 422
            assert client.get("/variables").json() == []  # all or nothing
            assert client.post("/variables/_import", content=exported.text).json() == {
                "imported": len(ROUND_TRIP)
            }
            restored = client.get("/variables").json()
    finally:
        fresh.stop()
    strip = [{k: v[k] for k in ("name", "type", "value", "tags", "doc")} for v in original]
    assert [{k: v[k] for k in ("name", "type", "value", "tags", "doc")} for v in restored] == strip


def test_an_alias_bomb_is_refused_before_it_is_built_and_changes_nothing(
    storage: Storage,
) -> None:
    """A YAML of a few hundred bytes of nested aliases cost the storage 10-28 CPU-seconds and
    about 580 MB, then a 504; a few thousand nested brackets, seconds in PyYAML's scanner."""
    bomb = "a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n" + "".join(
        f"{b}: &{b} [{', '.join([f'*{a}'] * 9)}]\n"
        for a, b in zip("abcdefgh", "bcdefghi", strict=True)
    )
    with httpx.Client(base_url=storage.url, timeout=10) as client:
        put(client, "kept", "number", 1.5)
        for document in (bomb, "variables: &v [*v]\n", "[" * 5000 + "]" * 5000):
            refused = client.post("/variables/_import", content=document)
            assert refused.status_code == 422, document[:40]
            assert refused.json()["error"]["code"] == "invalid_import"
        assert (
            "values" in client.post("/variables/_import", content=bomb).json()["error"]["message"]
        )
        assert [v["name"] for v in client.get("/variables").json()] == ["kept"]


def test_history_over_http(storage: Storage) -> None:
    with httpx.Client(base_url=storage.url) as client:
        for i in range(3):
            put(client, "speed", "number", i * 10)
        history = client.get("/variables/speed/history").json()
    assert [h["value"] for h in history] == [20, 10, 0]


def test_kill_9_during_writes_loses_no_acknowledged_write(home: Path) -> None:
    """Writers run flat out while the storage process is killed with SIGKILL, again and
    again. Every write that was acknowledged must be there afterwards, and the database
    must pass SQLite's integrity check."""
    data_dir = home / "crash"
    port = free_port()
    acknowledged: dict[str, int] = {}
    lock = threading.Lock()
    rng = random.Random(4)
    for round_no in range(6):
        storage = Storage(home, data_dir, port)
        stop = threading.Event()

        def writer(
            w: int, rn: int = round_no, url: str = storage.url, stop: threading.Event = stop
        ) -> None:
            i = 0
            with httpx.Client(base_url=url, timeout=5) as client:
                while not stop.is_set():
                    name = f"r{rn}_w{w}_{i}"
                    try:
                        response = put(client, name, "number", i)
                    except httpx.HTTPError:
                        return  # the process is gone: this write was never acknowledged
                    if response.status_code == 200:
                        with lock:
                            acknowledged[name] = i
                        # Rewrite a shared variable too, so pages are updated, not only added.
                        try:
                            put(client, f"shared_{w}", "number", i)
                        except httpx.HTTPError:
                            return
                    i += 1

        threads = [threading.Thread(target=writer, args=(w,)) for w in range(4)]
        for t in threads:
            t.start()

        # Killed mid-flow: after some writes of this round (however slowly they come),
        # at a random moment.
        def written(rn: int = round_no) -> bool:
            with lock:
                return sum(n.startswith(f"r{rn}_") for n in acknowledged) >= 20

        wait_for(written, 60, what="writes acknowledged")
        time.sleep(rng.uniform(0.0, 0.4))
        storage.kill()
        stop.set()
        for t in threads:
            t.join()
        storage.stop()
    assert len(acknowledged) > 100, len(acknowledged)
    print(f"{len(acknowledged)} acknowledged writes across 6 kills")
    final = Storage(home, data_dir, port)
    try:
        with httpx.Client(base_url=final.url) as client:
            stored = {v["name"]: v["value"] for v in client.get("/variables").json()}
    finally:
        final.stop()
    missing = [name for name in acknowledged if stored.get(name) != acknowledged[name]]
    assert not missing, f"{len(missing)} acknowledged writes lost, e.g. {missing[:5]}"
    db = sqlite3.connect(data_dir / "variables.sqlite")
    assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
