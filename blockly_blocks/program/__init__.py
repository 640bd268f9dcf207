"""Program control: a line in the output, a pause for the operator, the end of the run.

A category of blocks in one folder: blocks.json declares them, generator.py and functions.py
hold what its entries name, words.json their words in other languages."""
