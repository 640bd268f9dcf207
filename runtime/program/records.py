"""What the program service has running, kept on disk, so a crash of the service leaves a
record: on the next start a run that was live is marked failed with the reason, and the
control leases it took are released (they would otherwise block a re-run until they lapse).
The file holds lease tokens: it is readable by the runtime's user only."""

from __future__ import annotations

import json
import logging
import os
import time
from pathlib import Path
from typing import Any

from openpendant.runtime.kit.words import words
from openpendant.runtime.program.models import ErrorInfo, RunStatus

log = logging.getLogger(__name__)

LIVE = ("starting", "running", "paused")
CRASHED = (
    "the program service stopped during this run (it crashed or was killed); the robots "
    "it was moving were halted"
)


class RunRecords:
    def __init__(self, path: Path | None) -> None:
        self.path = path
        self.entries: dict[str, dict[str, Any]] = {}
        if path is not None and path.is_file():
            try:
                loaded = json.loads(path.read_text())
                self.entries = loaded if isinstance(loaded, dict) else {}
            except (OSError, ValueError) as exc:
                log.warning("could not read %s: %s", path, exc)

    def last_run(self) -> int:
        return max(
            (int(e.get("status", {}).get("run", 0)) for e in self.entries.values()), default=0
        )

    def crashed(self) -> list[tuple[str, dict[str, str]]]:
        """Runs that were live when the service stopped: each marked failed now; returns
        (program, leases the run took) for each, for the caller to release."""
        found = []
        for name, entry in self.entries.items():
            status = entry.get("status", {})
            if status.get("state") not in LIVE:
                continue
            status.update(
                state="error",
                ended=time.time(),
                error=ErrorInfo(
                    message=CRASHED,
                    kind="crash",
                    code="service_crashed",
                    words=words("run.crashed"),
                ).model_dump(),
            )
            found.append((name, dict(entry.get("leases", {}))))
            entry["leases"] = {}
        if found:
            self._save()
        return found

    def status(self, name: str) -> RunStatus | None:
        entry = self.entries.get(name)
        if entry is None:
            return None
        return RunStatus.model_validate(entry["status"])

    def update(self, status: RunStatus, leases: dict[str, str]) -> None:
        recorded = status.model_copy(update={"output": []})
        self.entries[status.program] = {"status": recorded.model_dump(), "leases": leases}
        self._save()

    def forget(self, name: str) -> None:
        if self.entries.pop(name, None) is not None:
            self._save()

    def _save(self) -> None:
        if self.path is None:
            return
        temporary = self.path.with_suffix(".tmp")
        try:
            descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            with os.fdopen(descriptor, "w") as out:
                json.dump(self.entries, out)
            os.replace(temporary, self.path)
        except OSError as exc:
            log.warning("could not record the program runs in %s: %s", self.path, exc)
