"""Programs in the variable storage (`program.<name>`, type `program`, with its history):
saved from a Blockly workspace (the Python generated here) or from hand-written Python,
each checked against the sandbox policy before it is kept."""

from __future__ import annotations

from typing import Any

from openpendant.blockly_blocks.workspace import parse_json
from openpendant.runtime.interfaces.variables import StoredProgram, Variable
from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.program.compiler import Compiler
from openpendant.runtime.program.models import (
    PREFIX,
    TAG,
    ProblemInfo,
    Program,
    ProgramImported,
    ProgramSummary,
    Saved,
    check_program_name,
)
from openpendant.runtime.program.program_file import file_bytes, read_file, save_body
from openpendant.runtime.variable_storage.client import StorageClient


class ProgramLibrary:
    def __init__(self, storage: StorageClient, compiler: Compiler) -> None:
        self.storage = storage
        self.compiler = compiler

    async def save(self, name: str, body: bytes) -> Saved:
        """Body: {"workspace": <Blockly JSON>} or {"python": "<code>"}."""
        check_program_name(name)
        prepared = await self.compiler.prepare_save(body)
        variable = await self.storage.put(PREFIX + name, "program", prepared.stored, tags=[TAG])
        return Saved(
            name=name,
            python=prepared.python,
            version=variable.version,
            blocks=prepared.blocks,
            problems=prepared.problems,
        )

    async def export_file(self, name: str) -> bytes:
        return file_bytes(await self.get(name))

    async def import_file(self, name: str, body: bytes) -> ProgramImported:
        """Saves a program file as `name` (a new version if it exists: the old one stays in
        its history)."""
        check_program_name(name)
        document = read_file(body)
        saved = await self.save(name, save_body(document))
        same = saved.python.split("\n") == document.python
        return ProgramImported(
            **saved.model_dump(), generated_as_in_file=same if document.source == "blocks" else None
        )

    async def runnable(self, name: str) -> tuple[str, list[ProblemInfo]]:
        """A saved program's Python, and why it may not run (none for hand-written Python)."""
        stored = StoredProgram.model_validate((await self._variable(name)).value)
        if stored.source != "blocks" or stored.workspace_json is None:
            return stored.python, []
        return stored.python, await self.compiler.problems(stored.workspace_json)

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
