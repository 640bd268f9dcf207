"""Simulated robot: URDF kinematics, a 500 Hz loop that tracks commands under the joint
limits with ruckig, simulated E-stop and faults. A real driver, not a test double."""
