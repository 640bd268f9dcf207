"""A block's chosen name or option, checked while its Python is generated: a fixed dropdown's
value must be one of its options, a name (a robot, a waypoint, a signal, filled in by the UI
from the runtime) short, printable and there at all."""

from __future__ import annotations

from openpendant.blockly_blocks.catalog import static_options
from openpendant.blockly_blocks.generator import Generator, block_kind
from openpendant.blockly_blocks.workspace import Block, WorkspaceError
from openpendant.runtime.kit.words import words

MAX_NAME = 128


def choice(block: Block, g: Generator, name: str) -> str:
    options = static_options(block.type, name)
    if options is not None:
        return g.option(block, name, options)
    text = g.text_field(block, name)
    if not text:
        raise WorkspaceError(
            f"block {block.type}: no {name.lower()} chosen",
            block.id,
            words("program.nothing_chosen", block=block_kind(block)),
        )
    if not len(text) <= MAX_NAME or not text.isprintable():
        raise WorkspaceError(f"block {block.type}: {name} must be a short name", block.id)
    return text
