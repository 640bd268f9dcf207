"""What program code may say: RestrictedPython's policy (no underscore names, guarded
attribute, item, iteration and write access), tightened for robot programs: no imports, no
classes, no generators or coroutines, none of the builtins that reach the interpreter, and
`**` routed through a guard that refuses numbers too large to compute."""

from __future__ import annotations

import ast
import warnings
from dataclasses import dataclass
from types import CodeType
from typing import Any

from RestrictedPython.compile import compile_restricted_exec
from RestrictedPython.transformer import RestrictingNodeTransformer

PROGRAM_FILENAME = "<program>"
MAX_SOURCE_CHARS = 2_000_000

# Names no program may mention, even as its own variable: shadowing them would be harmless,
# but a clear refusal at compile time beats a NameError in the middle of a run.
FORBIDDEN_NAMES = frozenset(
    {
        "eval",
        "exec",
        "compile",
        "open",
        "input",
        "breakpoint",
        "help",
        "globals",
        "locals",
        "vars",
        "dir",
        "getattr",
        "setattr",
        "delattr",
        "hasattr",
        "type",
        "object",
        "super",
        "memoryview",
        "bytearray",
        "classmethod",
        "staticmethod",
        "property",
        "exit",
        "quit",
        "printed",
    }
)


class ProgramCompileError(Exception):
    """The code breaks the policy or is not Python; `errors` has one line per problem."""

    def __init__(self, errors: list[str], line: int | None = None) -> None:
        super().__init__("; ".join(errors))
        self.errors = errors
        self.line = line


class ProgramPolicy(RestrictingNodeTransformer):
    def visit_Import(self, node: ast.Import) -> ast.AST:
        self.error(node, "imports are not allowed in programs; use the program functions")
        return node

    def visit_ImportFrom(self, node: ast.ImportFrom) -> ast.AST:
        self.error(node, "imports are not allowed in programs; use the program functions")
        return node

    def visit_ClassDef(self, node: ast.ClassDef) -> ast.AST:
        self.error(node, "class definitions are not allowed in programs")
        return node

    def visit_Yield(self, node: ast.Yield) -> ast.AST:
        self.error(node, "generators (yield) are not allowed in programs")
        return node

    def visit_YieldFrom(self, node: ast.YieldFrom) -> ast.AST:
        self.error(node, "generators (yield from) are not allowed in programs")
        return node

    def visit_AsyncFunctionDef(self, node: ast.AsyncFunctionDef) -> ast.AST:
        self.error(node, "async functions are not allowed in programs")
        return node

    def visit_Await(self, node: ast.Await) -> ast.AST:
        self.error(node, "await is not allowed in programs")
        return node

    def visit_AsyncFor(self, node: ast.AsyncFor) -> ast.AST:
        self.error(node, "async for is not allowed in programs")
        return node

    def visit_AsyncWith(self, node: ast.AsyncWith) -> ast.AST:
        self.error(node, "async with is not allowed in programs")
        return node

    def visit_With(self, node: ast.With) -> ast.AST:
        self.error(node, "with statements are not allowed in programs")
        return node

    def visit_Name(self, node: ast.Name) -> Any:
        if node.id in FORBIDDEN_NAMES:
            self.error(node, f'"{node.id}" is not available in programs')
            return node
        return super().visit_Name(node)

    def visit_arg(self, node: ast.arg) -> Any:
        if node.arg in FORBIDDEN_NAMES:
            self.error(node, f'"{node.arg}" is not available in programs')
        return super().visit_arg(node)

    def visit_FunctionDef(self, node: ast.FunctionDef) -> Any:
        if node.name in FORBIDDEN_NAMES:
            self.error(node, f'"{node.name}" is not available in programs')
        if node.decorator_list:
            self.error(node, "decorators are not allowed in programs")
        return super().visit_FunctionDef(node)

    def visit_BinOp(self, node: ast.BinOp) -> Any:
        node = self.node_contents_visit(node)
        if isinstance(node.op, ast.Pow):
            # Route through the guard: 10 ** (10 ** 8) would hold the CPU for minutes.
            name = ast.copy_location(ast.Name("_pow_", ast.Load()), node)
            call = ast.Call(func=name, args=[node.left, node.right], keywords=[])
            return ast.copy_location(call, node)
        return node


@dataclass(frozen=True)
class CompiledProgram:
    code: CodeType
    source: str


def compile_program(source: str, filename: str = PROGRAM_FILENAME) -> CompiledProgram:
    """Compile under the policy, or raise ProgramCompileError naming every problem."""
    if not isinstance(source, str):
        raise ProgramCompileError(["a program is text"])
    if len(source) > MAX_SOURCE_CHARS:
        raise ProgramCompileError([f"the program is longer than {MAX_SOURCE_CHARS} characters"])
    if "\x00" in source:
        raise ProgramCompileError(["the program holds a NUL character"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SyntaxWarning)
        try:
            result = compile_restricted_exec(source, filename, policy=ProgramPolicy)
        except (RecursionError, MemoryError) as exc:
            raise ProgramCompileError([f"the program is nested too deeply ({exc})"]) from exc
        except (SyntaxError, ValueError, TypeError) as exc:
            raise ProgramCompileError([f"the program could not be compiled: {exc}"]) from exc
    if result.errors or result.code is None:
        errors = list(result.errors) or ["the program could not be compiled"]
        raise ProgramCompileError(errors, _first_line(errors))
    return CompiledProgram(result.code, source)


def _first_line(errors: list[str]) -> int | None:
    for error in errors:
        head = error.split(":", 1)[0]
        if head.startswith("Line "):
            try:
                return int(head[5:])
            except ValueError:
                return None
    return None
