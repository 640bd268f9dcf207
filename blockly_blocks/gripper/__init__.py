"""Grippers: activate, open and close one, set its force, wait for a grip, ask whether it
holds a part.

A category of blocks in one folder: blocks.json declares them, generator.py, functions.py and
handlers.py hold what its entries name, words.json their words in other languages."""
