"""Whether the sign-in a ticket was given to still stands, read from the auth store by a
process other than the gateway (the jog service) without changing anything in it.

A session stands while its row is there and it has not expired; an API token while it has
not been revoked. The gateway keeps a session's latest use in memory and writes it back at
most every TOUCH_EVERY s, so, read from the file, a session left unused for almost the
whole idle limit may be seen to end up to that much early, never late."""

from __future__ import annotations

import sqlite3
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.store import session_expired
from openpendant.runtime.kit.tickets import Ticket


@dataclass(frozen=True)
class Standing:
    role: Role | None  # the sign-in's role now; None: it is over
    why: str = ""  # why it is over


class SignIns:
    def __init__(
        self,
        path: Path,
        *,
        idle_seconds: float,
        absolute_seconds: float,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.path = path
        self.idle = idle_seconds
        self.absolute = absolute_seconds
        self.clock = clock
        self._db: sqlite3.Connection | None = None
        self._lock = threading.Lock()

    def _connection(self) -> sqlite3.Connection:
        if self._db is None:
            # mode=rw: never creates the file (the gateway does, private to the runtime's user).
            uri = self.path.resolve().as_uri() + "?mode=rw"
            self._db = sqlite3.connect(uri, uri=True, timeout=1.0, check_same_thread=False)
        return self._db

    def close(self) -> None:
        with self._lock:
            if self._db is not None:
                self._db.close()
                self._db = None

    def standing(self, ticket: Ticket) -> Standing:
        """Blocking (SQLite): call it off the event loop."""
        try:
            with self._lock:
                if ticket.kind == "token":
                    return self._token(self._connection(), ticket)
                return self._session(self._connection(), ticket)
        except sqlite3.Error:
            # What cannot be confirmed does not stand: the socket closes, the robot halts.
            self.close()
            return Standing(None, "sign_in_unknown")

    def _token(self, db: sqlite3.Connection, ticket: Ticket) -> Standing:
        row = db.execute("SELECT role FROM tokens WHERE id = ?", (ticket.sign_in,)).fetchone()
        if row is None:
            return Standing(None, "token_revoked")
        return Standing(Role.named(row[0]))

    def _session(self, db: sqlite3.Connection, ticket: Ticket) -> Standing:
        row = db.execute(
            "SELECT u.role, s.created, s.last_seen FROM sessions s "
            "JOIN users u ON u.name = s.user WHERE s.id = ? AND s.user = ?",
            (ticket.sign_in, ticket.user),
        ).fetchone()
        if row is not None:
            if session_expired(row[1], row[2], self.clock(), self.idle, self.absolute):
                return Standing(None, "session_expired")
            return Standing(Role.named(row[0]))
        # The session is gone: say what ended it, where the store still shows it.
        user = db.execute("SELECT role FROM users WHERE name = ?", (ticket.user,)).fetchone()
        if user is None:
            return Standing(None, "user_removed")
        if user[0] != Role(ticket.role).name:
            return Standing(None, "role_changed")
        return Standing(None, "session_ended")  # signed out, or a new password
