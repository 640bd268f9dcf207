"""Variable types and the SQLite store (in-process; the service tests go over HTTP)."""

from __future__ import annotations

import json
import math
import sqlite3
from pathlib import Path
from typing import Any

import pytest

from openpendant.runtime.kit.errors import Conflict, InvalidValue, NotFound
from openpendant.runtime.variable_storage.store import VariableStore, version_bytes
from openpendant.runtime.variable_storage.types import types

UNIT_Q = [0.0, 0.0, 0.7071067811865476, 0.7071067811865476]

# One valid value per registered type, and what must come back.
ROUND_TRIP: dict[str, Any] = {
    "number": 12.5,
    "string": "pick from bin ‹A› — ok",
    "bool": True,
    "joint_waypoint": {"joints": [0.1, -1.2, 1.3, -0.5, -1.57, 0.0], "robot": "robot"},
    "pose_waypoint": {
        "pose": {"position": [0.4, 0.1, 0.3], "orientation": UNIT_Q},
        "frame": "base",
        "robot": "robot",
    },
    "pose": {"position": [1.0, 2.0, 3.0], "orientation": [0.0, 0.0, 0.0, 1.0]},
    "frame": {"pose": {"position": [0.5, 0.0, 0.0], "orientation": UNIT_Q}, "parent": "world"},
    "list": [1, "two", [3.0], {"four": 4}],
    "json": {"a": [1, 2, {"b": None}], "c": "d"},
    "device": {
        "uuid": "abc",
        "local_name": "robot2",
        "kind": "robot",
        "model": "ur5",
        "name": "sim",
        "url": "http://127.0.0.1:1234",
    },
    "scene_object": {
        "shape": "cylinder",
        "size": [0.04, 0.5],
        "mesh": None,
        "pose": {"position": [0.5, 0.0, 0.25], "orientation": UNIT_Q},
        "attached_to": None,
        "keep_out": False,
        "color": "#8a94a6",
    },
    "tool": {
        "tcp": {"position": [0.0, 0.0, 0.15], "orientation": UNIT_Q},
        "payload": {"mass": 1.5, "center_of_mass": [0.0, 0.0, 0.05]},
    },
    "calibration_board": {
        "kind": "charuco",
        "squares_x": 9,
        "squares_y": 6,
        "square": 0.03,
        "marker": 0.022,
        "dictionary": "5x5_100",
    },
    "camera_calibration": {
        "camera": "camera",
        "intrinsics": {
            "width": 1280,
            "height": 800,
            "fx": 1108.5,
            "fy": 1108.7,
            "cx": 639.4,
            "cy": 399.8,
            "distortion": [-0.08, 0.03, 0.0, 0.0, 0.0],
        },
        "rms": 0.12,
        "uncertainty": {"fx": 0.4, "fy": 0.4},
        "frame_errors": [0.1, 0.13],
        "board": None,
        "calibrated": 1795000000.0,
    },
    "detector": {
        "method": "template",
        "camera": "camera",
        "dictionary": "4x4_50",
        "marker_size": 0.032,
        "template": "iVBORw0KGgo=",
        "label": "bracket",
        "region": {"x": 10, "y": 20, "width": 300, "height": 200},
        "angle_step": 5.0,
        "scales": [0.9, 1.1, 0.05],
        "threshold": 0.8,
        "max_matches": 4,
        "height": 0.04,
        "model": None,
        "classes": [],
        "layout": "yolov8",
        "input_size": 640,
        "iou": 0.45,
    },
    "program": {
        "source": "blocks",
        "workspace_json": '{"blocks":{"blocks":[]}}',
        "python": "print('hi')\n",
    },
}

# Values each type must refuse.
REJECT: list[tuple[str, Any]] = [
    ("number", math.nan),
    ("number", math.inf),
    ("number", "1"),
    ("number", True),
    ("string", 3),
    ("bool", 1),
    ("bool", "true"),
    ("joint_waypoint", {"joints": [0.0, math.nan], "robot": "r"}),
    ("joint_waypoint", {"joints": [], "robot": "r"}),
    ("joint_waypoint", {"joints": [[0.0]], "robot": "r"}),
    ("joint_waypoint", {"joints": [0.0]}),
    ("joint_waypoint", {"joints": [0.0], "robot": "r", "extra": 1}),
    ("pose", {"position": [0.0, 0.0], "orientation": [0, 0, 0, 1]}),
    ("pose", {"position": [0.0, 0.0, math.inf], "orientation": [0, 0, 0, 1]}),
    ("pose", {"position": [0.0, 0.0, 0.0], "orientation": [0, 0, 0, 2]}),
    ("pose", {"position": [0.0, 0.0, 0.0], "orientation": [0, 0, 1]}),
    ("pose_waypoint", {"pose": {"position": [0, 0, 0], "orientation": [0, 0, 0, 1]}, "frame": ""}),
    ("frame", {"pose": "here"}),
    ("list", {"not": "a list"}),
    ("list", [1.0, math.nan]),
    ("json", {"deep": [math.inf]}),
    (
        "device",
        {"uuid": "x", "local_name": "Robot 2", "kind": "robot", "model": "", "name": "", "url": ""},
    ),
    ("scene_object", {"shape": "box", "size": [0.1, 0.2]}),
    ("scene_object", {"shape": "sphere", "size": [-0.1]}),
    ("scene_object", {"shape": "box", "size": [0.1, 0.1, 0.1], "mesh": "package://x/y.stl"}),
    ("program", {"source": "cobol", "python": ""}),
    ("program", {"source": "python"}),
    ("tool", {"tcp": {"position": [0.0, 0.0, 3.0]}}),
    ("tool", {"payload": {"mass": -1.0}}),
    ("tool", {"payload": {"mass": math.nan}}),
    ("calibration_board", {"squares_x": 9, "squares_y": 6, "square": 0.03, "marker": 0.04}),
    ("calibration_board", {"squares_x": 9, "squares_y": 6, "square": 0.03, "dictionary": "7x7"}),
    ("camera_calibration", {"camera": "c", "intrinsics": {"width": 0}, "rms": 0.1}),
    ("detector", {"method": "aruco", "camera": "Camera 1"}),
    ("detector", {"camera": "camera", "dictionary": "9x9_9"}),
    ("detector", {"method": "template", "camera": "camera"}),
    ("detector", {"method": "neural", "camera": "camera"}),
    ("detector", {"method": "neural", "camera": "camera", "model": "../../etc/passwd.onnx"}),
    ("detector", {"camera": "camera", "scales": [1.2, 0.8, 0.1]}),
    ("no_such_type", 1),
]


@pytest.fixture
def store(tmp_path: Path) -> VariableStore:
    return VariableStore(tmp_path / "v.sqlite", history_depth=5)


def test_every_registered_type_has_a_round_trip_case() -> None:
    assert set(ROUND_TRIP) == set(types())


@pytest.mark.parametrize("type_name", sorted(ROUND_TRIP))
def test_round_trip_survives_reopening(tmp_path: Path, type_name: str) -> None:
    path = tmp_path / "v.sqlite"
    first = VariableStore(path)
    first.put(f"v_{type_name}", type_name, ROUND_TRIP[type_name], tags=["t"], doc="d")
    first.close()
    again = VariableStore(path)
    got = again.get(f"v_{type_name}")
    assert (got.type, got.value, got.tags, got.doc, got.version) == (
        type_name,
        ROUND_TRIP[type_name],
        ["t"],
        "d",
        1,
    )


@pytest.mark.parametrize(("type_name", "value"), REJECT)
def test_invalid_values_are_rejected_and_change_nothing(
    store: VariableStore, type_name: str, value: Any
) -> None:
    store.put("keep", "number", 1.0)
    with pytest.raises(InvalidValue):
        store.put("keep" if type_name == "number" else "new", type_name, value)
    assert store.get("keep").value == 1.0 and store.get("keep").version == 1
    with pytest.raises(NotFound):
        store.get("new")


@pytest.mark.parametrize("name", ["", "1abc", "_private", "a b", "a/b", "x" * 129, "ä"])
def test_bad_names_are_rejected(store: VariableStore, name: str) -> None:
    with pytest.raises(InvalidValue):
        store.put(name, "number", 1)


def test_quaternions_are_stored_normalised(store: VariableStore) -> None:
    store.put("p", "pose", {"position": [0, 0, 0], "orientation": [0, 0, 0, 1.0005]})
    assert store.get("p").value["orientation"] == [0.0, 0.0, 0.0, 1.0]


def test_versions_history_and_pruning(store: VariableStore) -> None:
    for i in range(8):
        store.put("n", "number", i)
    assert store.get("n").version == 8
    history = store.history("n")
    assert [h.version for h in history] == [8, 7, 6, 5, 4]  # depth 5
    assert [h.value for h in history] == [7, 6, 5, 4, 3]


def test_delete_keeps_history_and_versions_keep_counting(store: VariableStore) -> None:
    store.put("w", "string", "a")
    store.put("w", "string", "b")
    deleted = store.delete("w")
    assert deleted.value == "b"
    with pytest.raises(NotFound):
        store.get("w")
    history = store.history("w")
    assert history[0].deleted and history[1].value == "b"
    assert store.put("w", "string", "c").version == 4


def test_expected_version_prevents_lost_updates(store: VariableStore) -> None:
    store.put("c", "number", 0, expected_version=0)
    with pytest.raises(Conflict) as err:
        store.put("c", "number", 1, expected_version=0)
    assert err.value.code == "version_conflict"
    store.put("c", "number", 1, expected_version=1)
    assert store.get("c").value == 1


def test_type_of_a_variable_cannot_silently_change(store: VariableStore) -> None:
    store.put("x", "number", 1)
    with pytest.raises(Conflict):
        store.put("x", "string", "1")
    assert store.get("x").type == "number"


def test_tags_filter_and_type_filter(store: VariableStore) -> None:
    store.put("a", "number", 1, tags=["cell1", "pick"])
    store.put("b", "number", 2, tags=["cell1"])
    store.put("c", "string", "x", tags=["pick"])
    assert [v.name for v in store.query(tag="pick")] == ["a", "c"]
    assert [v.name for v in store.query(type_name="number")] == ["a", "b"]
    assert [v.name for v in store.query(tag="cell1", type_name="number")] == ["a", "b"]


def test_import_is_all_or_nothing(store: VariableStore) -> None:
    store.put("a", "number", 1)
    with pytest.raises(InvalidValue, match="nothing imported"):
        store.put_many(
            [
                {"name": "a", "type": "number", "value": 2},
                {"name": "b", "type": "number", "value": math.nan},
            ]
        )
    assert store.get("a").value == 1
    with pytest.raises(NotFound):
        store.get("b")
    store.put_many(
        [
            {"name": "a", "type": "number", "value": 2},
            {"name": "b", "type": "bool", "value": False, "tags": ["x"]},
        ]
    )
    assert store.get("a").value == 2 and store.get("b").tags == ["x"]


def test_database_is_wal_with_full_sync(store: VariableStore) -> None:
    db = sqlite3.connect(store.path)
    assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert store._db.execute("PRAGMA synchronous").fetchone()[0] == 2  # FULL
    assert store.integrity_check() == "ok"


def test_rename_moves_value_tags_and_doc_in_one_step(store: VariableStore) -> None:
    store.put("wp_old", "joint_waypoint", ROUND_TRIP["joint_waypoint"], tags=["cell"], doc="d")
    store.put("taken", "number", 1)
    with pytest.raises(Conflict):
        store.rename("wp_old", "taken")
    with pytest.raises(InvalidValue):
        store.rename("wp_old", "bad name")
    with pytest.raises(NotFound):
        store.rename("nothing", "x")
    old, new = store.rename("wp_old", "wp_new")
    assert (new.name, new.value, new.tags, new.doc) == ("wp_new", old.value, ["cell"], "d")
    with pytest.raises(NotFound):
        store.get("wp_old")
    assert store.history("wp_old")[0].deleted


# A writer's budget (issue 32): every version the history keeps counts, exactly.


def writer_bytes(name: str, value: Any, tags: list[str], writer: str) -> int:
    return version_bytes(name, json.dumps(value), json.dumps(tags), "", writer)


def test_a_writers_usage_is_every_version_the_history_keeps(store: VariableStore) -> None:
    big, tags = "x" * 1000, ["mine"]
    one = writer_bytes("n", big, tags, "program:a")
    for i in range(1, 8):  # depth 5: from the sixth on, each write pushes one out
        store.put("n", "string", big, tags=tags, writer="program:a", budget=5 * one)
        assert store.usage("program:a").model_dump() == {
            "writer": "program:a",
            "versions": min(i, 5),
            "bytes": min(i, 5) * one,
        }
    # Another writer's versions and the user's are not a's, and push a's out.
    store.put("n", "string", big, tags=tags, writer="program:b")
    store.put("n", "string", "y")
    assert store.usage("program:a").bytes == 3 * one
    assert store.usage("program:b").bytes == one
    assert store.usage("nobody").model_dump() == {"writer": "nobody", "versions": 0, "bytes": 0}


def test_a_write_past_the_budget_is_refused_and_changes_nothing(store: VariableStore) -> None:
    big, tags = "x" * 1000, ["mine"]
    one = writer_bytes("n", big, tags, "program:a")
    for _ in range(5):
        store.put("n", "string", big, tags=tags, writer="program:a", budget=5 * one)
    # Emptying the value keeps the history it leaves: a new name's big value is too much.
    store.put("n", "string", "", tags=tags, writer="program:a", budget=5 * one)
    kept = store.usage("program:a")
    with pytest.raises(Conflict) as err:
        store.put("m", "string", big, tags=tags, writer="program:a", budget=5 * one)
    assert err.value.code == "storage_full"
    assert err.value.details["bytes"] > 5 * one and err.value.details["budget"] == 5 * one
    assert "history" in err.value.message
    assert store.usage("program:a") == kept
    with pytest.raises(NotFound):
        store.get("m")
    with pytest.raises(NotFound):
        store.history("m")
    with pytest.raises(InvalidValue):
        store.put("m", "string", "", budget=10)  # a budget without its writer
    with pytest.raises(InvalidValue):
        store.put("m", "string", "", writer="a b")


def in_use(path: Path) -> int:
    """The bytes of the database's pages in use (the WAL's newest included)."""
    db = sqlite3.connect(path)
    try:
        pages = db.execute("PRAGMA page_count").fetchone()[0]
        free = db.execute("PRAGMA freelist_count").fetchone()[0]
        return int((pages - free) * db.execute("PRAGMA page_size").fetchone()[0])
    finally:
        db.close()


def rewrite_and_empty(store: VariableStore, budget: int) -> tuple[int, Conflict | None]:
    """The loop of issue 32: 30 names, 21 rounds of 60 KB each emptied again; how many big
    values were written, and the refusal that stopped it."""
    written = 0
    try:
        for _ in range(21):
            for i in range(30):
                store.put(f"blob{i}", "string", "x" * 60000, writer="program:p", budget=budget)
                store.put(f"blob{i}", "string", "", writer="program:p", budget=budget)
                written += 1
    except Conflict as exc:
        return written, exc
    return written, None


def test_rewriting_and_emptying_big_values_is_stopped_at_the_budget(tmp_path: Path) -> None:
    """Issue 32: 30 variables written 21 times with 60 KB and emptied grew the database
    from 0.1 to 37.8 MB with every current value small."""
    store = VariableStore(tmp_path / "v.sqlite", history_depth=20)
    budget = 1024 * 1024
    before = in_use(store.path)
    written, refused = rewrite_and_empty(store, budget)
    assert refused is not None and refused.code == "storage_full"
    assert 15 <= written <= 17  # a mebibyte of 60 KB versions, no more
    assert store.usage("program:p").bytes <= budget
    # What the store keeps of it: the budget and a few pages of SQLite's own.
    assert in_use(store.path) - before <= budget + 64 * 1024


def test_a_schema_1_store_is_migrated_and_its_versions_count_for_nobody(tmp_path: Path) -> None:
    path = tmp_path / "v.sqlite"
    old = sqlite3.connect(path)
    old.executescript(
        "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);"
        "INSERT INTO meta VALUES ('schema_version', '1');"
        "CREATE TABLE variables (name TEXT PRIMARY KEY, type TEXT NOT NULL, value TEXT NOT NULL,"
        " tags TEXT NOT NULL, doc TEXT NOT NULL, created REAL NOT NULL, updated REAL NOT NULL,"
        " version INTEGER NOT NULL);"
        "CREATE TABLE history (name TEXT NOT NULL, version INTEGER NOT NULL, type TEXT NOT NULL,"
        " value TEXT, tags TEXT NOT NULL, doc TEXT NOT NULL, updated REAL NOT NULL,"
        " deleted INTEGER NOT NULL DEFAULT 0, PRIMARY KEY (name, version));"
        "INSERT INTO variables VALUES ('n', 'number', '1', '[]', '', 0, 0, 1);"
        "INSERT INTO history VALUES ('n', 1, 'number', '1', '[]', '', 0, 0);"
    )
    old.close()
    store = VariableStore(path)
    assert store.get("n").value == 1 and store.history("n")[0].value == 1
    assert store.put("n", "number", 2, writer="program:p", budget=1000).version == 2
    assert store.usage("program:p").versions == 1
    meta = store._db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
    assert meta == ("2",)
    store.close()
    assert VariableStore(path).usage("program:p").versions == 1  # reopened: nothing redone
