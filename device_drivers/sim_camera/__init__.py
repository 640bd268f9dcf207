"""The simulated camera: the shared simulated cell seen through a known camera model."""
