"""Stored variables: values kept in the variable storage between runs.

A category of blocks in one folder: blocks.json declares them, generator.py, functions.py and
handlers.py hold what its entries name, words.json their words in other languages."""
