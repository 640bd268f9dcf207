"""The sandbox's own functions: the block markers and what Blockly's standard blocks need.
Importing this package registers them in `base.REGISTRY`. The blocks' categories bring
their own (blockly_blocks/<category>/functions.py, named by their blocks), as plugins do."""

from openpendant.sandbox.library import blocks, markers
from openpendant.sandbox.library.base import REGISTRY

__all__ = ["REGISTRY", "blocks", "markers"]
