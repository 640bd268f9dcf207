"""Program figures, measured at the driver's command log where motion is concerned:

- first motion: a run request sent to the webui → the first trajectory the driver received;
- stop, during a move: a POST .../stop reaching the program service (also: the webui,
  the client) → the halt the driver received; and the Program panel's stop message on the
  program socket, from the client's send;
- generation of a 500-block workspace, in-process;
- a sandbox function's round trip (worker → program service → device manager → worker),
  timed inside the program; and the bare pipe round trip with a host that answers at once."""

from __future__ import annotations

import asyncio
import contextlib
import json
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
from websockets.sync.client import ClientConnection, connect

from openpendant.blockly_blocks.generate import generate
from openpendant.runtime.bench.harness.blocks import block, number, stack, text, workspace
from openpendant.runtime.bench.harness.jog import Cell
from openpendant.runtime.bench.harness.processes import Runtime, wait_for
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.sandbox.supervisor import ProgramRun, RunState

FIGURES = (
    "program_first_motion",
    "program_stop_to_halt",
    "program_stop_to_halt_socket",
    "generate_500_blocks",
    "sandbox_call_roundtrip_p50",
    "sandbox_pipe_roundtrip_p50",
)
INFO = load_robot_info("ur5")
A = [0.5, -1.3, 1.6, -1.87, -1.57, 0.0]
B = [-0.5, -1.3, 1.6, -1.87, -1.57, 0.0]
CALLS = 200
TIMED_CALLS = f"""
times = []
for k in range({CALLS}):
    t = seconds_since_start()
    joint_positions()
    times.append(round((seconds_since_start() - t) * 1000, 4))
for k in range(0, len(times), 40):
    print(times[k:k + 40])
"""


def driver_entry(cell: Cell, after: int, kind: str, timeout: float = 10.0) -> float:
    def found() -> float | None:
        for entry in cell.robot.commands(after):
            if entry["type"] == kind:
                return float(entry["t"])
        return None

    return wait_for(found, timeout, interval=0.005, what=f"the driver's {kind}")


def put(cell: Cell, name: str, python: str) -> None:
    response = cell.runtime.api("PUT", f"/programs/{name}", json={"python": python})
    response.raise_for_status()


def run_to_end(cell: Cell, name: str, start: bool = True) -> dict[str, Any]:
    if start:
        cell.runtime.api("POST", f"/programs/{name}/run", json={"leases": {"robot": cell.token}})

    def ended() -> dict[str, Any] | None:
        status: dict[str, Any] = cell.runtime.api("GET", f"/programs/{name}/status").json()
        return status if status["state"] in ("finished", "error", "stopped") else None

    return wait_for(ended, 60, what=f"{name} to end")


def client(cell: Cell) -> httpx.Client:
    """A kept connection: a new client per request costs tens of ms of its own (TLS set-up)."""
    return httpx.Client(
        base_url=f"{cell.runtime.url}/api", timeout=10.0, headers=cell.runtime.auth("operator")
    )


def first_motion(cell: Cell, trials: int) -> list[float]:
    put(cell, "to_a", f"move_joint({[round(v, 4) for v in A]!r})")
    put(cell, "to_b", f"move_joint({[round(v, 4) for v in B]!r})")
    times = []
    http = client(cell)
    for k in range(trials):
        name = "to_a" if k % 2 else "to_b"
        after = cell.robot.last_command_seq()
        sent = time.time()
        # As the Program panel sends it: the robot chosen, the tab's leases.
        http.post(f"/programs/{name}/run", json={"robot": "robot", "leases": {"robot": cell.token}})
        times.append((driver_entry(cell, after, "trajectory") - sent) * 1000)
        run_to_end(cell, name, start=False)
        time.sleep(0.3)  # the service's spare worker is ready again, as between real runs
    return times


def drain(socket: ClientConnection) -> None:
    with contextlib.suppress(TimeoutError):
        while True:
            socket.recv(timeout=0)


def stop_to_halt(cell: Cell, trials: int) -> dict[str, list[float]]:
    """During a long move: by HTTP, from the stop reaching the program service (and the
    webui, and leaving the client); by the Program panel's way, a message on the program
    socket, from the client's send."""
    put(cell, "slow", f"set_speed(5)\nmove_joint({[round(v, 4) for v in A]!r})")
    put(cell, "back", f"move_joint({[round(v, 4) for v in B]!r})")
    times: dict[str, list[float]] = {
        "socket": [],
        "http_from_service": [],
        "http_from_webui": [],
        "http_from_client": [],
    }
    http = client(cell)
    with connect(
        cell.runtime.ws_url("/programs/_ws"), additional_headers=cell.runtime.auth("operator")
    ) as socket:
        for k in range(trials):
            run_to_end(cell, "back")
            after = cell.robot.last_command_seq()
            http.post("/programs/slow/run", json={"leases": {"robot": cell.token}})
            driver_entry(cell, after, "trajectory")
            time.sleep(0.2)
            after = cell.robot.last_command_seq()
            sent = time.time()
            if k % 2 == 0:
                drain(socket)  # read what was pushed, as the pendant does
                sent = time.time()
                socket.send(json.dumps({"type": "stop", "program": "slow"}))
                times["socket"].append((driver_entry(cell, after, "halt") - sent) * 1000)
            else:
                stopped = http.post("/programs/slow/stop").json()
                halted = driver_entry(cell, after, "halt")
                times["http_from_service"].append((halted - stopped["stop_received"]) * 1000)
                times["http_from_webui"].append((halted - stopped["stop_request_start"]) * 1000)
                times["http_from_client"].append((halted - sent) * 1000)
            run_to_end(cell, "slow", start=False)
            cell.ready()
    return times


def round_trips(cell: Cell) -> list[float]:
    put(cell, "calls", TIMED_CALLS)
    status = run_to_end(cell, "calls")
    values: list[float] = []
    for line in status["output"]:
        values += [float(v) for v in line["text"].strip("[]").split(",")]
    return values


class ImmediateHost:
    async def call(self, fn: str, args: dict[str, Any]) -> Any:
        return [0.0] * 6

    async def halt(self) -> None:
        pass


def pipe_round_trips() -> list[float]:
    async def go() -> list[float]:
        run = ProgramRun(TIMED_CALLS, ImmediateHost())
        await run.start()
        assert await run.wait(60) is RunState.finished, run.error
        await run.close()
        return [float(v) for o in run.output for v in o.text.strip("[]").split(",")]

    return asyncio.run(go())


def big_workspace(blocks: int = 500) -> dict[str, Any]:
    prints = [block("text_print", TEXT=text(f"line {i}")) for i in range(blocks // 4)]
    waits = [block("time_wait", SECONDS=number(0.1)) for _ in range(blocks // 4)]
    steps = [b for pair in zip(prints, waits, strict=True) for b in pair]
    return workspace(stack(*steps))


def generation_times(samples: int) -> tuple[list[float], int]:
    ws = big_workspace()
    times, count = [], 0
    for _ in range(samples):
        started = time.perf_counter()
        count = generate(ws).blocks
        times.append((time.perf_counter() - started) * 1000)
    return times, count


def run() -> list[Figure]:
    trials = 3 if quick() else 20
    home = Path(tempfile.mkdtemp(prefix="bench-program-"))
    runtime = Runtime(home)
    try:
        runtime.wait_ready()
        cell = Cell(runtime)
        cell.ready()
        first = first_motion(cell, trials)
        halts = stop_to_halt(cell, max(4, trials * 3 // 5))
        calls = round_trips(cell)
    finally:
        runtime.stop()
    pipe = pipe_round_trips()
    generation, count = generation_times(5 if quick() else 50)
    return [
        Figure(
            "program_first_motion",
            statistics.median(first),
            "ms",
            "≤ 100 ms",
            statistics.median(first) <= 100,
            {"trials": trials, "p99": percentile(first, 99), "max": max(first)},
        ),
        Figure(
            "program_stop_to_halt",
            statistics.median(halts["http_from_service"]),
            "ms",
            "≤ 2 ms (a control cycle)",
            statistics.median(halts["http_from_service"]) <= 2.0,
            {
                "trials": len(halts["http_from_service"]),
                "max": max(halts["http_from_service"]),
                "from": "POST .../stop reaching the program service",
                "from_webui_median": statistics.median(halts["http_from_webui"]),
                "from_client_median": statistics.median(halts["http_from_client"]),
            },
        ),
        Figure(
            "program_stop_to_halt_socket",
            statistics.median(halts["socket"]),
            "ms",
            details={
                "trials": len(halts["socket"]),
                "max": max(halts["socket"]),
                "from": "the Program panel's stop message leaving the client",
            },
        ),
        Figure(
            "generate_500_blocks",
            statistics.median(generation),
            "ms",
            details={"blocks": count, "samples": len(generation)},
        ),
        Figure(
            "sandbox_call_roundtrip_p50",
            percentile(calls, 50),
            "ms",
            details={"calls": len(calls), "p99": percentile(calls, 99), "call": "joint_positions"},
        ),
        Figure(
            "sandbox_pipe_roundtrip_p50",
            percentile(pipe, 50),
            "ms",
            details={"calls": len(pipe), "p99": percentile(pipe, 99)},
        ),
    ]
