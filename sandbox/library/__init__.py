"""The sandbox function library: one module per category. Importing this package registers
every function in `base.REGISTRY`, the names programs can call."""

from openpendant.sandbox.library import blocks, gripper, io, poses, program, robot, store, timing
from openpendant.sandbox.library.base import REGISTRY

__all__ = ["REGISTRY", "blocks", "gripper", "io", "poses", "program", "robot", "store", "timing"]
