"""The motion service: kinematics, planned moves, the collision scene and avoidance."""
