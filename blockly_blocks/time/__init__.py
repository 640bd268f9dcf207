"""Time: waits that the pause button holds, and waiting for a condition with a timeout.

A category of blocks in one folder: blocks.json declares them, generator.py and functions.py
hold what its entries name, words.json their words in other languages."""
