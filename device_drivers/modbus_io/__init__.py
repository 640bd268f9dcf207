"""Modbus TCP I/O blocks and grippers on pymodbus: signals named by a register map."""
