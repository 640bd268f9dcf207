"""Jog service: hold-to-run joint and Cartesian jogging, planned hold-to-run moves, teaching."""
