"""Sandbox for user programs: the restricted-Python policy, the per-run worker process and the
function library. Built by the programs issue; this package holds no code yet."""
