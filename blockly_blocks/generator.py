"""The server-side Python generator: a workspace becomes a program in the sandbox's dialect
(no imports; helpers are sandbox functions), each statement preceded by
`at_block('<block id>')`, the marker that highlights, pauses, steps and breaks there.

Each block type has one generator function, registered with `statement` or `value`; a
value generator returns an expression that is safe to use as an operand (atomic or
parenthesized), so no precedence table is needed. `generate.py` loads them all and turns a
workspace into its program."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from openpendant.blockly_blocks.names import NameTable
from openpendant.blockly_blocks.workspace import Block, Workspace, WorkspaceError
from openpendant.runtime.kit.words import Words, words

INDENT = "    "
StatementGen = Callable[[Block, "Generator"], list[str]]
ValueGen = Callable[[Block, "Generator"], str]

STATEMENTS: dict[str, StatementGen] = {}
VALUES: dict[str, ValueGen] = {}
# Blocks that are a statement or a value depending on their settings (lists_getIndex).
DUAL: dict[str, Callable[[Block], bool]] = {}
DEFINITIONS = ("procedures_defnoreturn", "procedures_defreturn")


def statement(*types: str) -> Callable[[StatementGen], StatementGen]:
    def register(fn: StatementGen) -> StatementGen:
        for kind in types:
            STATEMENTS[kind] = fn
        return fn

    return register


def value(*types: str) -> Callable[[ValueGen], ValueGen]:
    def register(fn: ValueGen) -> ValueGen:
        for kind in types:
            VALUES[kind] = fn
        return fn

    return register


@dataclass(frozen=True)
class Problem:
    block: str
    message: str
    words: Words


@dataclass(frozen=True)
class Generated:
    python: str
    blocks: int
    block_lines: dict[str, int]  # block id -> line of its marker
    # What keeps it from running: empty inputs, blocks that are not part of the program.
    problems: list[Problem] = field(default_factory=list)


class Generator:
    def __init__(self, workspace: Workspace) -> None:
        self.workspace = workspace
        self.names = NameTable()
        self.procedure: Block | None = None  # the definition being generated
        self.procedures: dict[str, Block] = {}
        self.problems: list[Problem] = []

    # Fields --------------------------------------------------------------------------------

    def option(self, block: Block, name: str, options: Iterable[str]) -> str:
        chosen = block.field(name)
        allowed = tuple(options)
        if chosen not in allowed:
            raise WorkspaceError(
                f"block {block.type}: {name} is {str(chosen)[:40]!r}, not one of {allowed}",
                block.id,
            )
        return str(chosen)

    def text_field(self, block: Block, name: str) -> str:
        text = block.field(name)
        if not isinstance(text, str):
            raise WorkspaceError(f"block {block.type}: {name} must be text", block.id)
        return text

    def number_field(self, block: Block, name: str) -> float | int:
        raw = block.field(name)
        try:
            number = float(raw) if isinstance(raw, str) else raw
        except ValueError:
            raise WorkspaceError(f"block {block.type}: {name} is not a number", block.id) from None
        if isinstance(number, bool) or not isinstance(number, int | float):
            raise WorkspaceError(f"block {block.type}: {name} is not a number", block.id)
        if number != number or abs(number) == float("inf"):
            raise WorkspaceError(f"block {block.type}: {name} must be finite", block.id)
        return int(number) if float(number).is_integer() and abs(number) < 2**53 else number

    def variable(self, block: Block, name: str = "VAR") -> str:
        ref = block.field(name)
        var_id = ref.get("id") if isinstance(ref, dict) else None
        if var_id not in self.workspace.variables:
            raise WorkspaceError(
                f"block {block.type} uses a variable that does not exist",
                block.id,
                words("program.unknown_variable", block=block_kind(block)),
            )
        return self.var_name(var_id)

    def var_name(self, var_id: str) -> str:
        return self.names.get("variable", var_id, self.workspace.variables[var_id])

    # Code ----------------------------------------------------------------------------------

    def value(
        self, block: Block, name: str, default: str = "None", *, optional: bool = False
    ) -> str:
        """The code of the block plugged into input `name`; an empty one is a problem (the
        program may be saved, not run), unless the input is optional."""
        child = block.inputs.get(name)
        if child is None:
            if not optional:
                self.problem(
                    block,
                    f"{describe(block)}: {input_label(name)} is empty",
                    words("program.input_empty", block=block_kind(block), input=input_words(name)),
                )
            return default
        gen = VALUES.get(child.type)
        if gen is None or (child.type in DUAL and DUAL[child.type](child)):
            raise WorkspaceError(
                f"a {child.type} block cannot be used as a value",
                child.id,
                words("program.not_a_value", type=child.type),
            )
        return gen(child, self)

    def body(self, block: Block, name: str) -> list[str]:
        """An indented statement body; `pass` when empty."""
        lines = self.stack(block.inputs.get(name))
        return indent(lines or ["pass"])

    def stack(self, first: Block | None) -> list[str]:
        lines: list[str] = []
        block = first
        while block is not None:
            gen = STATEMENTS.get(block.type)
            if gen is None or (block.type in DUAL and not DUAL[block.type](block)):
                raise not_a_statement(block)
            lines.append(f"at_block({block.id!r})")
            lines.extend(gen(block, self))
            block = block.next
        return lines

    def problem(self, block: Block, message: str, said: Words) -> None:
        self.problems.append(Problem(block.id, message, said))

    def program(self) -> list[str]:
        top = sorted(self.workspace.top, key=lambda b: (b.y, b.x))
        for block in top:
            if block.type in DEFINITIONS:
                name = self.text_field(block, "NAME")
                if name in self.procedures:
                    raise WorkspaceError(
                        f"two functions are named {name!r}",
                        block.id,
                        words("program.two_functions", name=name),
                    )
                self.procedures[name] = block
        variables = [self.var_name(v) for v in self.workspace.variables]
        lines = [f"{v} = None" for v in variables]
        for block in top:
            if block.type in DEFINITIONS:
                self.procedure = block
                lines += ["", *STATEMENTS[block.type](block, self)]
                self.procedure = None
        runnable = [b for b in top if b.type not in DEFINITIONS and _is_statement(b)]
        values = [b for b in top if b.type not in DEFINITIONS and not _is_statement(b)]
        if lines and runnable:
            lines.append("")
        for block in runnable:
            lines += self.stack(block)
        for loose in values:
            if loose.next is not None:
                raise not_a_statement(loose)
            VALUES[loose.type](loose, self)  # not run, as in Blockly, but still checked
        # The program is the stack that starts highest (then leftmost); another stack lying
        # apart would run after it unseen: it must be attached, or deleted.
        for loose in [*runnable[1:], *values]:
            self.problem(
                loose,
                f"{describe(loose)} is not part of the program: {LOOSE}",
                words("program.loose", block=block_kind(loose)),
            )
        return lines


LOOSE = "attach it to the program's blocks, or delete it"
INPUT_LABELS = {
    "BOOL": "the condition",
    "CONDITION": "the condition",
    "TIMES": "the number of times",
    "TARGET": "the target",
    "LIST": "the list",
    "TEXT": "the text",
    "VALUE": "the value",
    "NUM": "the number",
    "FROM": "the start",
    "TO": "the end",
    "BY": "the step",
}


# The same labels as words a UI says in its language: program.input.<word>.
INPUT_WORDS = {
    "BOOL": "condition",
    "CONDITION": "condition",
    "TIMES": "times",
    "TARGET": "target",
    "LIST": "list",
    "TEXT": "text",
    "VALUE": "value",
    "NUM": "number",
    "FROM": "start",
    "TO": "end",
    "BY": "step",
}


def input_label(name: str) -> str:
    if name.startswith("IF") and name[2:].isdigit():
        return "the condition"
    return INPUT_LABELS.get(name, f"the {name.lower().replace('_', ' ')} input")


def input_words(name: str) -> Words:
    if name.startswith("IF") and name[2:].isdigit():
        return words("program.input.condition")
    if name in INPUT_WORDS:
        return words(f"program.input.{INPUT_WORDS[name]}")
    return words("program.input.named", name=name.lower().replace("_", " "))


def block_kind(block: Block) -> str:
    """A block as people see it: its type without the category prefix."""
    return block.type.split("_", 1)[-1].replace("_", " ")


def describe(block: Block) -> str:
    return f"the '{block_kind(block)}' block"


def not_a_statement(block: Block) -> WorkspaceError:
    return WorkspaceError(
        f"a {block.type} block cannot be used as a statement",
        block.id,
        words("program.not_a_statement", type=block.type),
    )


def _is_statement(block: Block) -> bool:
    if block.type in DUAL:
        return DUAL[block.type](block)
    return block.type in STATEMENTS


def indent(lines: list[str]) -> list[str]:
    return [INDENT + line if line else line for line in lines]


def py_string(text: str) -> str:
    return repr(str(text))
