"""Variable storage: typed, versioned variables in one SQLite file (WAL, synchronous=FULL)."""
