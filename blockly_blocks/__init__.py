"""Blockly block definitions, the toolbox and the server-side Python generator. Built by the
programs issue; this package holds no code yet."""
