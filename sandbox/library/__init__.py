"""The sandbox function library: one module per category. Importing this package registers
every function in `base.REGISTRY`, the names programs can call."""

from sandbox.library import blocks, gripper, io, poses, program, robot, store, timing
from sandbox.library.base import REGISTRY

__all__ = ["REGISTRY", "blocks", "gripper", "io", "poses", "program", "robot", "store", "timing"]
