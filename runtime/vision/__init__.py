"""The vision service: camera calibration (intrinsic, extrinsic, robot origin) and detection."""
