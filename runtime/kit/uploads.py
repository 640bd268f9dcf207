"""The API paths that take a file's raw bytes (not JSON), and the largest file each takes:
the gateway's guard lets only these through, and the service checks the same bound."""

MAX_MODEL_BYTES = 512 * 1024 * 1024  # above the largest YOLO networks (about 260 MB)

# Path prefix (as the gateway sees it) → bound in bytes.
UPLOADS: dict[str, int] = {"/api/vision/models/": MAX_MODEL_BYTES}
