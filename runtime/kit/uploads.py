"""The API paths that take a file's raw bytes (not JSON), and the largest file each takes:
the gateway's guard lets only these through, and the service checks the same bound."""

MAX_MODEL_BYTES = 512 * 1024 * 1024  # above the largest YOLO networks (about 260 MB)

# How long the gateway waits for the service to take a file it has received whole (it checks
# the file: OpenCV reads a network), counted from when the gateway had it.
UPLOAD_TIMEOUT = 120.0

# Path prefix (as the gateway sees it) → bound in bytes.
UPLOADS: dict[str, int] = {"/api/vision/models/": MAX_MODEL_BYTES}
