"""Real runtimes, drivers and clients on loopback, for the benchmarks and the test suite."""
