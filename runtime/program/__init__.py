"""The program service: Blockly programs stored, generated and run in the sandbox."""
