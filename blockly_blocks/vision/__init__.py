"""Vision: what a detector finds, the detection with a marker id or class, its grip pose,
a pose above it, how many there are.

A category of blocks in one folder: blocks.json declares them, generator.py, functions.py and
handlers.py hold what its entries name, words.json their words in other languages."""
