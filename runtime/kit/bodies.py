"""How a route that reads its own body (bounded before it is parsed, or not JSON) describes
that body in the API's document: FastAPI sees no parameter to describe."""

from __future__ import annotations

from typing import Any


def described_body(media_type: str, schema: dict[str, Any]) -> dict[str, Any]:
    """The route's `openapi_extra`: a required body of this type."""
    return {"requestBody": {"required": True, "content": {media_type: {"schema": schema}}}}


# A YAML file's text (an export of the variables, an OpenCV calibration).
YAML_TEXT = described_body("application/x-yaml", {"type": "string"})
