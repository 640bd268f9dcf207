"""Programs in the variable storage (`program.<name>`, type `program`, with its history):
saved from a Blockly workspace (the Python generated here) or from hand-written Python,
each checked against the sandbox policy before it is kept."""

from __future__ import annotations

import asyncio
from typing import Any

from blockly_blocks.generator import Generated, generate
from blockly_blocks.workspace import WorkspaceError, dump_json, parse_json
from runtime.interfaces.variables import StoredProgram, Variable
from runtime.kit.errors import InvalidValue, NotFound
from runtime.program.models import (
    PREFIX,
    TAG,
    ProblemInfo,
    Program,
    ProgramSummary,
    Saved,
    check_program_name,
)
from runtime.variable_storage.client import StorageClient
from sandbox.policy import ProgramCompileError, compile_program


def workspace_error(exc: WorkspaceError) -> InvalidValue:
    details = {"block": exc.block} if exc.block else None
    return InvalidValue(exc.message, code="invalid_workspace", details=details)


def compile_error(exc: ProgramCompileError) -> InvalidValue:
    return InvalidValue(
        f"the program breaks the sandbox policy: {exc}",
        code="invalid_program",
        details={"errors": exc.errors, "line": exc.line},
    )


def problem_infos(generated: Generated) -> list[ProblemInfo]:
    return [ProblemInfo(block=p.block, message=p.message) for p in generated.problems]


def read_request(body: bytes) -> dict[str, Any]:
    """A save or preview body: {"workspace": <Blockly JSON>} or {"python": "<code>"}."""
    try:
        data = parse_json(body)
    except WorkspaceError as exc:
        raise workspace_error(exc) from None
    if not isinstance(data, dict) or ("workspace" in data) == ("python" in data):
        raise InvalidValue('send {"workspace": <Blockly JSON>} or {"python": "<code>"}')
    return data


def workspace_text(data: dict[str, Any]) -> str:
    try:
        return dump_json(data["workspace"])
    except WorkspaceError as exc:
        raise workspace_error(exc) from None


def generate_checked(raw: bytes | str) -> Generated:
    """Parse, generate and compile a workspace; any problem is an InvalidValue."""
    try:
        generated = generate(raw)
        compile_program(generated.python)
    except WorkspaceError as exc:
        raise workspace_error(exc) from None
    except ProgramCompileError as exc:
        raise compile_error(exc) from None
    return generated


class ProgramLibrary:
    def __init__(self, storage: StorageClient) -> None:
        self.storage = storage

    async def save(self, name: str, body: bytes) -> Saved:
        """Body: {"workspace": <Blockly JSON>} or {"python": "<code>"}."""
        check_program_name(name)
        data = read_request(body)
        if "python" in data:
            python = data["python"]
            if not isinstance(python, str):
                raise InvalidValue("python must be text")
            try:
                compile_program(python)
            except ProgramCompileError as exc:
                raise compile_error(exc) from None
            stored = StoredProgram(source="python", python=python)
            blocks, problems = 0, []
        else:
            workspace_json = workspace_text(data)
            # Generation is CPU work (a 5,000-block workspace takes a while): off the loop.
            generated = await asyncio.to_thread(generate_checked, workspace_json)
            stored = StoredProgram(
                source="blocks", workspace_json=workspace_json, python=generated.python
            )
            python, blocks = generated.python, generated.blocks
            problems = problem_infos(generated)
        variable = await self.storage.put(PREFIX + name, "program", stored.model_dump(), tags=[TAG])
        return Saved(
            name=name, python=python, version=variable.version, blocks=blocks, problems=problems
        )

    async def problems(self, program: Program) -> list[ProblemInfo]:
        """Why a saved program may not run (none for hand-written Python)."""
        if program.source != "blocks":
            return []
        generated = await asyncio.to_thread(generate_checked, dump_json(program.workspace))
        return problem_infos(generated)

    async def get(self, name: str) -> Program:
        return _program(name, await self._variable(name))

    async def _variable(self, name: str) -> Variable:
        check_program_name(name)
        try:
            return await self.storage.get(PREFIX + name)
        except NotFound:
            raise NotFound(f"no program {name!r}", code="unknown_program") from None

    async def list(self) -> list[ProgramSummary]:
        found = await self.storage.query(type_name="program")
        return [
            ProgramSummary(
                name=v.name.removeprefix(PREFIX),
                source=str(v.value.get("source", "")),
                version=v.version,
                updated=v.updated,
            )
            for v in found
            if v.name.startswith(PREFIX)
        ]

    async def delete(self, name: str) -> None:
        await self.get(name)
        await self.storage.delete(PREFIX + name)

    async def rename(self, name: str, to: str) -> Program:
        check_program_name(to)
        await self.get(name)
        await self.storage.http.post(f"/variables/{PREFIX + name}/rename", json={"to": PREFIX + to})
        return await self.get(to)

    async def duplicate(self, name: str, to: str) -> Program:
        check_program_name(to)
        original = await self._variable(name)
        if await self._exists(to):
            raise InvalidValue(f"a program named {to!r} exists already", code="exists")
        copy = await self.storage.put(PREFIX + to, "program", original.value, tags=[TAG])
        return _program(to, copy)

    async def _exists(self, name: str) -> bool:
        try:
            await self.storage.get(PREFIX + name)
        except NotFound:
            return False
        return True


def _program(name: str, variable: Variable) -> Program:
    stored = StoredProgram.model_validate(variable.value)
    workspace: Any = None
    if stored.workspace_json is not None:
        workspace = parse_json(stored.workspace_json)
    return Program(
        name=name,
        source=stored.source,
        workspace=workspace,
        python=stored.python,
        version=variable.version,
        updated=variable.updated,
    )
