"""The small world the simulated devices share: parts on a table, picked by a simulated
gripper at the simulated robot's TCP, seen by simulated sensors."""
