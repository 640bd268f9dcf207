"""Long vision operations (solves, calibration runs): each runs as a task that reports its
progress and stage, can be cancelled (its result is then dropped, nothing is stored), and
keeps its result until the user saves or discards it."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from typing import Any, Literal

from openpendant.runtime.kit.errors import Conflict, NotFound, OpenPendantError
from openpendant.runtime.vision.models import OperationStatus

KEEP = 50
log = logging.getLogger(__name__)
Kind = Literal["intrinsic", "extrinsic", "robot_origin"]


class Operation:
    def __init__(self, op_id: str, kind: Kind, subject: str) -> None:
        self.id, self.kind, self.subject = op_id, kind, subject
        self.state: Literal["running", "done", "failed", "cancelled"] = "running"
        self.progress, self.stage, self.error = 0.0, "starting", ""
        self.result: Any = None  # the model the operation made
        self.saved = False
        self.task: asyncio.Task[None] | None = None
        self.ended = asyncio.Event()

    def report(self, progress: float, stage: str) -> None:
        """Called from the operation's task or its worker thread."""
        if self.state == "running":
            self.progress, self.stage = max(self.progress, min(progress, 1.0)), stage

    def status(self) -> OperationStatus:
        return OperationStatus(
            id=self.id,
            kind=self.kind,
            state=self.state,
            progress=round(self.progress, 3),
            stage=self.stage,
            error=self.error,
            result=self.result,
        )


Work = Callable[[Operation], Awaitable[Any]]


class Operations:
    def __init__(self) -> None:
        self.all: OrderedDict[str, Operation] = OrderedDict()
        self._ids = itertools.count(1)

    def start(self, kind: Kind, subject: str, work: Work) -> Operation:
        op = Operation(f"{kind}-{next(self._ids)}", kind, subject)
        self.all[op.id] = op
        op.task = asyncio.create_task(self._run(op, work))
        while len(self.all) > KEEP:
            oldest = next(iter(self.all.values()))
            if oldest.state == "running":
                break
            del self.all[oldest.id]
        return op

    async def _run(self, op: Operation, work: Work) -> None:
        try:
            op.result = await work(op)
            op.state, op.progress, op.stage = "done", 1.0, "done"
        except asyncio.CancelledError:
            op.state, op.stage, op.result = "cancelled", "cancelled", None
        except OpenPendantError as exc:
            op.state, op.error = "failed", exc.message
        except Exception as exc:  # reported to the user, not lost in the task
            log.exception("vision operation %s failed", op.id)
            op.state, op.error = "failed", f"{type(exc).__name__}: {exc}"
        finally:
            op.ended.set()

    def get(self, op_id: str) -> Operation:
        op = self.all.get(op_id)
        if op is None:
            raise NotFound(f"no vision operation {op_id!r}", code="no_such_operation")
        return op

    async def wait(self, op_id: str, timeout: float) -> Operation:
        op = self.get(op_id)
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(op.ended.wait(), timeout)
        return op

    async def cancel(self, op_id: str) -> Operation:
        op = self.get(op_id)
        if op.state == "running" and op.task is not None:
            op.task.cancel()
            await op.ended.wait()
        return op

    def finished(self, op_id: str) -> Operation:
        op = self.get(op_id)
        if op.state != "done":
            raise Conflict(f"{op_id} is {op.state}: nothing to save", code="not_done")
        return op

    async def close(self) -> None:
        for op in list(self.all.values()):
            if op.task is not None and not op.task.done():
                op.task.cancel()
        await asyncio.gather(
            *(op.task for op in self.all.values() if op.task is not None), return_exceptions=True
        )
