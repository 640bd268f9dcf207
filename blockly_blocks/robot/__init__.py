"""The robot: which one the program commands, its moves (joint, linear, relative, home),
the speed, where it is, its tool.

A category of blocks in one folder: blocks.json declares them, generator.py, functions.py and
handlers.py hold what its entries name, words.json their words in other languages."""
