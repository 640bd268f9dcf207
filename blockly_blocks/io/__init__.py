"""I/O: digital and analog signals of a robot controller or an I/O block by name, and
waiting for an input.

A category of blocks in one folder: blocks.json declares them, generator.py, functions.py and
handlers.py hold what its entries name, words.json their words in other languages."""
