"""`openpendant bench`: the benchmarks of DESIGN.md's figures (one module each, `bench_*.py`),
run against real processes on loopback, printed as a table and written as JSON."""
