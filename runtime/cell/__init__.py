"""The cell as services see it: every added robot with its live joints and its base in the
world, and the stored scene, read from the device manager's links and the variable storage."""
