"""Typed device clients: one per device kind, the same methods as its interface, over the
device manager's one link to each device (runtime/links)."""
