"""The program service: /programs/… to save (generating the Python), load, list, rename,
duplicate and delete programs, and to run, pause, resume, step and stop them."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from typing import Any

from fastapi import APIRouter, FastAPI, Query, Request, Response, WebSocket

from openpendant.blockly_blocks.catalog import definitions, toolbox, words
from openpendant.blockly_blocks.workspace import MAX_WORKSPACE_BYTES, allow_deep_json
from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.kit.app import create_app
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.kit.request_start import RequestStart, received_at
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.kit.websocket import Fanout
from openpendant.runtime.motion.client import MotionClient
from openpendant.runtime.program.compiler import Compiler, problem_infos
from openpendant.runtime.program.library import ProgramLibrary
from openpendant.runtime.program.models import (
    SOURCE_BODY,
    BlockCatalog,
    BreakpointsRequest,
    Generated,
    Program,
    ProgramImported,
    ProgramSummary,
    RenameRequest,
    RunRequest,
    RunStatus,
    Saved,
)
from openpendant.runtime.program.program_file import (
    FILE_BODY,
    MAX_FILE_BYTES,
    SUFFIX,
    ProgramFile,
)
from openpendant.runtime.program.records import RunRecords
from openpendant.runtime.program.runs import Runs
from openpendant.runtime.variable_storage.client import StorageClient


async def read_body(request: Request, limit: int = MAX_WORKSPACE_BYTES + 1024) -> bytes:
    body = b""
    async for chunk in request.stream():
        body += chunk
        if len(body) > limit:
            raise InvalidValue(f"the body is larger than {limit} bytes")
    return body


def program_router(library: ProgramLibrary, runs: Runs, fanout: Fanout) -> APIRouter:
    router = APIRouter(prefix="/programs")

    @router.get("/_blocks")
    async def blocks() -> BlockCatalog:
        """Block definitions by category and the toolbox, for the editor."""
        return BlockCatalog(definitions=definitions(), toolbox=toolbox(), words=words())

    @router.post("/_generate", openapi_extra=SOURCE_BODY)
    async def preview(request: Request) -> Generated:
        """The Python of {"workspace": <Blockly JSON>}, as saving it would give; nothing kept."""
        generated = await library.compiler.preview(await read_body(request))
        return Generated(
            python=generated.python,
            blocks=generated.blocks,
            problems=problem_infos(generated),
        )

    @router.websocket("/_ws")
    async def live(ws: WebSocket) -> None:
        """Every run's status as it changes; a {"type": "stop", "program": name} message
        stops a run (the pendant's Stop: no HTTP request on the way)."""

        async def control(message: Any) -> None:
            if not isinstance(message, dict) or message.get("type") != "stop":
                expected = 'expected {"type": "stop", "program": <name>}'
                raise InvalidValue(expected, code="bad_message")
            name = message.get("program")
            if not isinstance(name, str):
                raise InvalidValue("which program to stop: a name", code="bad_message")
            await runs.stop(name)

        initial = [runs.status(name).model_dump_json() for name in runs.runs]
        await fanout.serve(ws, initial, on_message=control)

    @router.post("/_stop")
    async def stop_all() -> dict[str, list[str]]:
        """The pendant's STOP: every running program stops (and halts what it moved)."""
        return {"stopped": await runs.stop_live("STOP pressed")}

    @router.get("")
    async def listing() -> list[ProgramSummary]:
        return await library.list()

    @router.get("/{name}")
    async def get(name: str) -> Program:
        return await library.get(name)

    @router.put("/{name}", openapi_extra=SOURCE_BODY)
    async def save(name: str, request: Request) -> Saved:
        """Body {"workspace": <Blockly JSON>} or {"python": "<code>"}; returns the Python."""
        return await library.save(name, await read_body(request))

    @router.get(
        "/{name}/file",
        responses={200: {"model": ProgramFile, "description": "the program's file"}},
        response_class=Response,
    )
    async def export_file(name: str) -> Response:
        """The program as a file (its blocks, and the Python generated from them)."""
        return Response(
            await library.export_file(name),
            media_type="application/json",
            headers={"Content-Disposition": f'attachment; filename="{name}{SUFFIX}"'},
        )

    @router.put("/{name}/file", openapi_extra=FILE_BODY)
    async def import_file(name: str, request: Request) -> ProgramImported:
        """A program file (GET …/file) saved as `name`, checked as a save is."""
        return await library.import_file(name, await read_body(request, MAX_FILE_BYTES))

    @router.delete("/{name}", status_code=204)
    async def delete(name: str) -> Response:
        await library.delete(name)
        return Response(status_code=204)

    @router.post("/{name}/rename")
    async def rename(name: str, body: RenameRequest) -> Program:
        return await library.rename(name, body.to)

    @router.post("/{name}/duplicate", status_code=201)
    async def duplicate(name: str, body: RenameRequest) -> Program:
        return await library.duplicate(name, body.to)

    @router.post("/{name}/run", status_code=202)
    async def run(name: str, body: RunRequest | None = None) -> RunStatus:
        return await runs.start(name, body or RunRequest())

    @router.post("/{name}/pause")
    async def pause(name: str) -> RunStatus:
        return await runs.pause(name)

    @router.post("/{name}/resume")
    async def resume(name: str) -> RunStatus:
        return await runs.resume(name)

    @router.post("/{name}/step")
    async def step(name: str) -> RunStatus:
        return await runs.step(name)

    @router.post("/{name}/stop")
    async def stop(name: str, request_start: RequestStart = None) -> RunStatus:
        return await runs.stop(name, request_start=received_at(request_start))

    @router.put("/{name}/breakpoints")
    async def breakpoints(name: str, body: BreakpointsRequest) -> RunStatus:
        return await runs.breakpoints(name, body.ids)

    @router.get("/{name}/status")
    async def status(name: str, after: int = Query(0, ge=0, le=2**53)) -> RunStatus:
        return runs.status(name, after)

    return router


def build_app(settings: RuntimeSettings, urls: dict[str, str]) -> FastAPI:
    allow_deep_json()
    storage = StorageClient(urls["variable_storage"])
    devices = Devices(urls["device_manager"], "program", settings.link.stale_after)
    motion = MotionClient(urls["motion"])
    compiler = Compiler()
    library = ProgramLibrary(storage, compiler)
    fanout = Fanout()
    records = RunRecords(settings.data_dir / "program-runs.json")
    runs = Runs(
        library,
        devices,
        motion,
        storage,
        fanout,
        records,
        runs_without_robots=settings.programs.runs_without_robots,
    )

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        await compiler.start()
        await devices.start()
        recovery = asyncio.create_task(runs.recover())
        try:
            yield
        finally:
            recovery.cancel()
            await runs.stop_all()
            await devices.close()
            await motion.aclose()
            await storage.aclose()
            await compiler.close()

    app = create_app("program", lifespan=lifespan)
    app.include_router(program_router(library, runs, fanout))
    return app
