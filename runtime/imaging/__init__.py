"""Image geometry that the camera drivers and the vision service share: calibration boards,
ArUco markers."""
