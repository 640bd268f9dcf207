"""Waypoints and poses: a taught waypoint, a pose from numbers, poses composed, inverted
and offset, and their parts.

A category of blocks in one folder: blocks.json declares them, generator.py, functions.py and
handlers.py hold what its entries name, words.json their words in other languages."""
