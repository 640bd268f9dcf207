"""`openpendant run`: start every service and the simulated devices, supervise, stop cleanly."""
