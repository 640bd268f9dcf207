"""Universal Robots controllers over RTDE (ur-rtde), and an emulator of their interfaces."""
