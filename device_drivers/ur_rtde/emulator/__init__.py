"""An emulator of a UR controller's interfaces on loopback, good enough that the unmodified
ur-rtde library drives it: RTDE (30004), the dashboard server (29999) and the script port
(30003), behind them the register protocol of ur-rtde's control script applied to a
simulated arm with joint limits, a protective stop and an E-stop. docs/dev/ur-rtde-protocol.md
has the protocol as ur-rtde 1.6.5 speaks it."""
