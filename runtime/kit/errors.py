"""One error type, mapped to an HTTP status and a JSON body {"error": {"code", "message"}};
with `words`, the message as a code and params a UI says in its own language."""

from __future__ import annotations

from typing import Any

from openpendant.runtime.kit.words import Words, words_of


class OpenPendantError(Exception):
    """An error a client can act on. Subclasses set the domain's default status."""

    status: int = 400
    code: str = "bad_request"

    def __init__(
        self,
        message: str,
        *,
        code: str | None = None,
        status: int | None = None,
        details: dict[str, Any] | None = None,
        words: Words | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.words = words
        if code is not None:
            self.code = code
        if status is not None:
            self.status = status
        self.details = details or {}

    def body(self) -> dict[str, Any]:
        error: dict[str, Any] = {"code": self.code, "message": self.message}
        if self.details:
            error["details"] = self.details
        if self.words is not None:
            error["words"] = self.words.body()
        return {"error": error}

    @classmethod
    def from_body(cls, status: int, body: Any) -> OpenPendantError:
        """Rebuild an error received from another service, as the class its status means,
        so callers can catch NotFound or Conflict whichever service raised it."""
        kind = BY_STATUS.get(status, cls)
        if isinstance(body, dict) and isinstance(body.get("error"), dict):
            err = body["error"]
            return kind(
                str(err.get("message", "")),
                code=str(err.get("code", "error")),
                status=status,
                details=err.get("details") if isinstance(err.get("details"), dict) else None,
                words=words_of(err.get("words")),
            )
        return kind(f"unexpected response (HTTP {status})", code="bad_response", status=status)


class NotFound(OpenPendantError):
    status = 404
    code = "not_found"


class Conflict(OpenPendantError):
    status = 409
    code = "conflict"


class InvalidValue(OpenPendantError):
    status = 422
    code = "invalid_value"


class Unavailable(OpenPendantError):
    status = 503
    code = "unavailable"


class RobotError(OpenPendantError):
    """A robot refused a command (limits, mode, state)."""

    status = 409
    code = "robot_error"


class StorageError(OpenPendantError):
    status = 400
    code = "storage_error"


class DeviceError(OpenPendantError):
    status = 400
    code = "device_error"


BY_STATUS: dict[int, type[OpenPendantError]] = {
    404: NotFound,
    409: Conflict,
    422: InvalidValue,
    503: Unavailable,
}
