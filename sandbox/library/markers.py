"""The marker the Blockly generator puts before every statement: where the program is, for
highlighting, pausing, stepping and breakpoints."""

from __future__ import annotations

from openpendant.sandbox.library.base import host, sandbox_function, text_arg


@sandbox_function
def at_block(block_id: str) -> None:
    """Where the program is, for highlighting, pausing, stepping and breakpoints."""
    host().at_block(text_arg(block_id, "block id", max_length=64))
