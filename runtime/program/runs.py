"""Program runs: at most one per program, each a sandboxed worker with its RunHost; status
with the current block and the output since a given line, for polling and the WebSocket."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import time

from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.kit.errors import Conflict, NotFound, OpenPendantError
from openpendant.runtime.kit.metrics import PROGRAM_RUNS
from openpendant.runtime.kit.websocket import Fanout
from openpendant.runtime.kit.words import Words, words
from openpendant.runtime.motion.client import MotionClient
from openpendant.runtime.program.host import RunHost
from openpendant.runtime.program.library import ProgramLibrary
from openpendant.runtime.program.models import (
    ErrorInfo,
    OutputEntry,
    ProblemInfo,
    RunRequest,
    RunStatus,
)
from openpendant.runtime.program.records import RunRecords
from openpendant.runtime.variable_storage.client import StorageClient
from openpendant.sandbox.supervisor import ProgramRun, RunLimits, WorkerPool

log = logging.getLogger(__name__)

PUSHED_OUTPUT = 100


class Active:
    def __init__(self, number: int, run: ProgramRun, host: RunHost) -> None:
        self.number = number
        self.run = run
        self.host = host
        self.received_stop: float | None = None
        self.stop_request_start: float | None = None


class Runs:
    def __init__(
        self,
        library: ProgramLibrary,
        devices: Devices,
        motion: MotionClient,
        storage: StorageClient,
        fanout: Fanout,
        records: RunRecords | None = None,
        runs_without_robots: int = 3,
    ) -> None:
        self.runs_without_robots = runs_without_robots
        self.library = library
        self.devices = devices
        self.motion = motion
        self.storage = storage
        self.fanout = fanout
        self.runs: dict[str, Active] = {}
        self.records = records or RunRecords(None)
        self._numbers = itertools.count(self.records.last_run() + 1)
        self._watchers: set[asyncio.Task[None]] = set()
        self.pool = WorkerPool()

    async def start(self, name: str, request: RunRequest) -> RunStatus:
        current = self.runs.get(name)
        if current is not None and not current.run.ended_state:
            raise Conflict(
                f"{name} is running; stop it first",
                code="busy",
                words=words("program.busy", program=name),
            )
        await self._room_for_a_run()
        python, problems = await self.library.runnable(name)
        if problems:
            first = problems[0].message
            more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
            said = _problems_words(name, problems)
            raise Conflict(
                f"{name} cannot run until it is complete: {first}{more}",
                code="program_has_problems",
                details={"problems": [p.model_dump() for p in problems]},
                words=said,
            )
        host = RunHost(
            f"program {name}",
            self.devices,
            self.motion,
            self.storage,
            robot=request.robot,
            leases=request.leases,
            on_lease=lambda: self._record(name),
            program=name,
        )
        limits = RunLimits(wall_seconds=request.time_limit or RunLimits.wall_seconds)
        number = next(self._numbers)
        run = ProgramRun(
            python,
            host,
            limits=limits,
            breakpoints=set(request.breakpoints),
            listener=lambda: self._publish(name),
            pool=self.pool,
        )
        active = Active(number, run, host)
        try:
            await run.start()
        except BaseException:
            await run.close()
            await host.close()
            raise
        self.runs[name] = active
        self._record(name)
        watcher = asyncio.create_task(self._finish(active))
        self._watchers.add(watcher)
        watcher.add_done_callback(self._watchers.discard)
        return self.status(name)

    async def _room_for_a_run(self) -> None:
        live = sum(1 for active in self.runs.values() if not active.run.ended_state)
        listed = sum(1 for d in self.devices.added.values() if d.get("kind") == "robot")
        if live < listed + self.runs_without_robots:
            return
        # The live list may trail a robot added a moment ago: the device manager decides.
        if live >= len(await self.devices.robot_names()) + self.runs_without_robots:
            raise Conflict(
                f"{live} programs are running, as many as may run at once here; stop one first",
                code="too_many_runs",
                words=words("program.too_many_runs", count=live),
            )

    async def _finish(self, active: Active) -> None:
        await active.run.wait()
        PROGRAM_RUNS.labels(active.run.state.value).inc()
        await active.host.close()
        await active.run.close()
        name = next((n for n, a in self.runs.items() if a is active), None)
        if name is not None:
            self._record(name)

    def _record(self, name: str) -> None:
        """On disk while it matters: a crash of this service leaves the run's record."""
        active = self.runs.get(name)
        if active is not None:
            ended = active.run.ended_state is not None and active.host.closed
            leases = {} if ended else dict(active.host.acquired)
            self.records.update(self.status(name), leases)

    async def recover(self) -> None:
        """Runs that were live when this service last stopped failed with it: recorded so,
        and the leases they took released (retried until the device manager answers)."""
        for name, leases in self.records.crashed():
            log.warning("program %s was running when the program service stopped", name)
            for robot, token in leases.items():
                while True:
                    try:
                        await self.devices.manager.release_lease(robot, token)
                        break
                    except OpenPendantError as exc:
                        if exc.status < 500:
                            break  # lapsed, or the robot was removed: nothing to free
                        await asyncio.sleep(0.5)

    def _active(self, name: str) -> Active:
        active = self.runs.get(name)
        if active is None:
            raise NotFound(f"{name} has not run since the service started", code="not_running")
        return active

    def _live(self, name: str) -> ProgramRun:
        run = self._active(name).run
        if run.ended_state:
            raise Conflict(f"{name} is not running ({run.state})", code="not_running")
        return run

    async def pause(self, name: str) -> RunStatus:
        """The robot stops on its path now (not at the end of its move), and the program
        waits at its next block."""
        run = self._live(name)
        await self._active(name).host.pause_motion(True)
        await run.pause()
        return self.status(name)

    async def resume(self, name: str) -> RunStatus:
        """The interrupted move goes on from where it stopped, and the program with it."""
        run = self._live(name)
        await self._active(name).host.pause_motion(False)
        await run.resume()
        return self.status(name)

    async def step(self, name: str) -> RunStatus:
        run = self._live(name)
        await self._active(name).host.pause_motion(False)
        await run.step()
        return self.status(name)

    async def stop(self, name: str, request_start: float | None = None) -> RunStatus:
        """`request_start`: when the stop reached the webui, if it came through it."""
        active = self._active(name)
        active.received_stop = time.time()
        active.stop_request_start = request_start
        await active.run.stop()
        return self.status(name)

    async def stop_live(self, reason: str) -> list[str]:
        """Every run still going, stopped at once (all together: stop always wins)."""
        live = [(n, a) for n, a in self.runs.items() if not a.run.ended_state]
        now = time.time()
        for _, active in live:
            active.received_stop = now
        await asyncio.gather(*(a.run.stop(reason) for _, a in live), return_exceptions=True)
        return [name for name, _ in live]

    async def stop_all(self) -> None:
        for active in list(self.runs.values()):
            with contextlib.suppress(Exception):
                await active.run.stop("the program service is shutting down")
        await self.pool.close()

    async def breakpoints(self, name: str, ids: list[str]) -> RunStatus:
        await self._active(name).run.set_breakpoints(set(ids))
        return self.status(name)

    def status(self, name: str, after: int = 0) -> RunStatus:
        active = self.runs.get(name)
        if active is None:
            return self.records.status(name) or RunStatus(program=name, state="idle")
        run = active.run
        error = None
        if run.error is not None:
            e = run.error
            error = ErrorInfo(
                message=e.message,
                kind=e.kind,
                line=e.line,
                block=e.block,
                code=e.code,
                words=e.words,
            )
        return RunStatus(
            program=name,
            run=active.number,
            state=run.state.value,
            block=run.block,
            pause_reason=run.pause_reason,
            message=run.message,
            output=[
                OutputEntry(
                    seq=o.seq, text=o.text, stream=o.stream, block=o.block, ts=o.ts, words=o.words
                )
                for o in run.output
                if o.seq > after
            ],
            error=error,
            robots=list(active.host.robots),
            isolation=run.isolation,
            started=run.started,
            ended=run.ended,
            stop_received=active.received_stop,
            stop_request_start=active.stop_request_start,
        )

    def _publish(self, name: str) -> None:
        """Each change, coalesced per program for slow clients; the latest output lines
        only (the rest is in GET status with `after`)."""
        if self.fanout.subscribers:
            status = self.status(name)
            status.output = status.output[-PUSHED_OUTPUT:]
            self.fanout.publish(status.model_dump_json(), key=name)


def _problems_words(program: str, problems: list[ProblemInfo]) -> Words | None:
    first = problems[0].words
    if first is None:
        return None
    if len(problems) == 1:
        return words("program.has_problems", program=program, problem=first)
    more = len(problems) - 1
    return words("program.has_problems_more", program=program, problem=first, more=more)
