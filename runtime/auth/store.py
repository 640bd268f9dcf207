"""Users, sessions and API tokens, in one SQLite file of the data directory (`auth.sqlite`).

Passwords and PINs are kept as argon2id hashes; session ids and API tokens only as SHA-256
digests (they are long random strings: a fast digest is enough, and a stolen file holds
nothing that logs in). The gateway is the only process that serves it; `openpendant token
create` on the runtime computer writes to it directly."""

from __future__ import annotations

import hashlib
import re
import secrets
import sqlite3
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.kit.errors import Conflict, InvalidValue, NotFound, OpenPendantError
from openpendant.runtime.kit.schema import AUTH, mark_version, refuse_newer

USERNAME = re.compile(r"^[a-z][a-z0-9_.-]{0,31}\Z")
MIN_PASSWORD = 10
MAX_PASSWORD = 256
PIN = re.compile(r"^[0-9]{4,8}\Z")
TOKEN_PREFIX = "opt_"
# Failed logins before a lockout, and how long the first one lasts (it doubles after each
# further failure, up to the last figure).
FREE_FAILURES = 5
FIRST_LOCKOUT = 30.0
LONGEST_LOCKOUT = 900.0
# A session's last use is written back at most this often (it is kept in memory between).
TOUCH_EVERY = 30.0

SCHEMA = """
CREATE TABLE IF NOT EXISTS users (
    name TEXT PRIMARY KEY,
    role TEXT NOT NULL,
    password TEXT NOT NULL,
    pin TEXT,
    created REAL NOT NULL,
    failed INTEGER NOT NULL DEFAULT 0,
    locked_until REAL NOT NULL DEFAULT 0
);
CREATE TABLE IF NOT EXISTS sessions (
    id TEXT PRIMARY KEY,
    user TEXT NOT NULL REFERENCES users(name) ON DELETE CASCADE,
    csrf TEXT NOT NULL,
    created REAL NOT NULL,
    last_seen REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS ended_sessions (
    id TEXT PRIMARY KEY,
    why TEXT NOT NULL,
    at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS tokens (
    id TEXT PRIMARY KEY,
    digest TEXT UNIQUE NOT NULL,
    name TEXT NOT NULL,
    role TEXT NOT NULL,
    created REAL NOT NULL,
    last_used REAL
);
"""


class Unauthenticated(OpenPendantError):
    status = 401
    code = "unauthenticated"


class LockedOut(OpenPendantError):
    status = 429
    code = "locked_out"


@dataclass(frozen=True)
class Identity:
    """Who a request comes from: a user's session, or an API token (`user` is its name)."""

    user: str
    role: Role
    via: str  # "session" | "token"
    session: str | None = None  # the session's id digest, to end it
    csrf: str | None = None
    token: str | None = None  # the API token's id


@dataclass(frozen=True)
class UserInfo:
    name: str
    role: str
    created: float
    has_pin: bool
    locked_until: float


@dataclass(frozen=True)
class TokenInfo:
    id: str
    name: str
    role: str
    created: float
    last_used: float | None


def private(path: Path) -> None:
    """The database and its write-ahead files, readable by the runtime's user only (the WAL
    holds recent rows too)."""
    for part in (path, path.with_name(path.name + "-wal"), path.with_name(path.name + "-shm")):
        if part.exists():
            part.chmod(0o600)


def digest(secret: str) -> str:
    return hashlib.sha256(secret.encode()).hexdigest()


def session_expired(
    created: float, last_seen: float, now: float, idle: float, absolute: float
) -> bool:
    return now - last_seen > idle or now - created > absolute


def check_username(name: str) -> str:
    if not USERNAME.match(name):
        raise InvalidValue(
            "a user name starts with a lowercase letter; lowercase letters, digits, '_', '.' "
            "and '-' only; at most 32 characters",
            code="invalid_name",
        )
    return name


def check_password(password: str) -> str:
    if not MIN_PASSWORD <= len(password) <= MAX_PASSWORD:
        raise InvalidValue(
            f"a password has {MIN_PASSWORD} to {MAX_PASSWORD} characters", code="weak_password"
        )
    return password


class AuthStore:
    def __init__(
        self,
        path: Path,
        *,
        idle_seconds: float = 3600.0,
        absolute_seconds: float = 12 * 3600.0,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.path = path
        self.idle = idle_seconds
        self.absolute = absolute_seconds
        self.clock = clock
        # argon2id at OWASP's recommended cost (19 MiB, 2 passes, 1 lane): a sign-in takes
        # tens of milliseconds of one core on the runtime computer, not 64 MiB and four.
        self.hasher = PasswordHasher(time_cost=2, memory_cost=19456, parallelism=1)
        path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
        refuse_newer(self._db, path, AUTH)  # before anything is written
        self._db.execute("PRAGMA foreign_keys = ON")
        self._db.execute("PRAGMA journal_mode = WAL")
        self._db.executescript(SCHEMA)
        mark_version(self._db, AUTH)
        private(path)
        self._lock = threading.Lock()
        self._touched: dict[str, float] = {}  # session id -> last use not yet written
        # Hashing a wrong user's password keeps a login's time the same whether or not the
        # user exists.
        self._dummy = self.hasher.hash(secrets.token_hex(8))

    @contextmanager
    def _tx(self) -> Iterator[sqlite3.Connection]:
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                yield self._db
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
            self._db.execute("COMMIT")

    def close(self) -> None:
        self._db.close()

    # Users -----------------------------------------------------------------------------------

    def user_count(self) -> int:
        with self._lock:
            return int(self._db.execute("SELECT COUNT(*) FROM users").fetchone()[0])

    def create_user(self, name: str, password: str, role: Role, *, first: bool = False) -> None:
        """`first`: only while there is no user at all (the set-up screen)."""
        check_username(name)
        hashed = self.hasher.hash(check_password(password))
        with self._tx() as db:
            if first and db.execute("SELECT COUNT(*) FROM users").fetchone()[0]:
                raise Conflict("the runtime is set up already", code="already_set_up")
            if db.execute("SELECT 1 FROM users WHERE name = ?", (name,)).fetchone():
                raise Conflict(f"there is a user {name!r} already", code="exists")
            db.execute(
                "INSERT INTO users (name, role, password, created) VALUES (?, ?, ?, ?)",
                (name, role.name, hashed, self.clock()),
            )

    def users(self) -> list[UserInfo]:
        with self._lock:
            rows = self._db.execute(
                "SELECT name, role, created, pin IS NOT NULL, locked_until FROM users ORDER BY name"
            ).fetchall()
        return [UserInfo(r[0], r[1], r[2], bool(r[3]), r[4]) for r in rows]

    def role_of(self, name: str) -> Role:
        with self._lock:
            row = self._db.execute("SELECT role FROM users WHERE name = ?", (name,)).fetchone()
        if row is None:
            raise NotFound(f"no user {name!r}", code="unknown_user")
        return Role.named(row[0])

    def set_role(self, name: str, role: Role) -> None:
        with self._tx() as db:
            self._keep_an_admin(db, name, role)
            db.execute("UPDATE users SET role = ? WHERE name = ?", (role.name, name))
            self._end_sessions(db, name, "role_changed")

    def set_password(self, name: str, password: str) -> None:
        hashed = self.hasher.hash(check_password(password))
        with self._tx() as db:
            self._require_user(db, name)
            db.execute(
                "UPDATE users SET password = ?, failed = 0, locked_until = 0 WHERE name = ?",
                (hashed, name),
            )
            self._end_sessions(db, name, "password_changed")

    def set_pin(self, name: str, pin: str | None) -> None:
        if pin is not None and not PIN.match(pin):
            raise InvalidValue("a PIN has 4 to 8 digits", code="invalid_pin")
        hashed = self.hasher.hash(pin) if pin is not None else None
        with self._tx() as db:
            self._require_user(db, name)
            db.execute("UPDATE users SET pin = ? WHERE name = ?", (hashed, name))

    def delete_user(self, name: str) -> None:
        with self._tx() as db:
            self._keep_an_admin(db, name, None)
            self._end_sessions(db, name, "user_removed")
            db.execute("DELETE FROM users WHERE name = ?", (name,))

    def _require_user(self, db: sqlite3.Connection, name: str) -> str:
        row = db.execute("SELECT role FROM users WHERE name = ?", (name,)).fetchone()
        if row is None:
            raise NotFound(f"no user {name!r}", code="unknown_user")
        return str(row[0])

    def _keep_an_admin(self, db: sqlite3.Connection, name: str, role: Role | None) -> None:
        current = self._require_user(db, name)
        if current != Role.admin.name or role == Role.admin:
            return
        admins = db.execute("SELECT COUNT(*) FROM users WHERE role = 'admin'").fetchone()[0]
        if admins <= 1:
            raise Conflict("the last administrator stays an administrator", code="last_admin")

    # Logging in ------------------------------------------------------------------------------

    def verify(self, name: str, secret: str, *, pin: bool = False) -> Role:
        """The user's role if `secret` is their password (or PIN); failures count towards a
        lockout, which doubles with each further failure."""
        now = self.clock()
        with self._lock:
            row = self._db.execute(
                "SELECT role, password, pin, failed, locked_until FROM users WHERE name = ?",
                (name,),
            ).fetchone()
        if row is not None and row[4] > now:
            raise LockedOut(
                f"too many failed logins: try again in {int(row[4] - now) + 1} s",
                details={"retry_after": int(row[4] - now) + 1},
            )
        stored = (row[2] if pin else row[1]) if row is not None else None
        if not self._matches(stored, secret):
            if row is not None:
                self._failed(name, int(row[3]) + 1, now)
            raise Unauthenticated(
                "wrong PIN" if pin else "wrong user name or password", code="wrong_credentials"
            )
        with self._tx() as db:
            db.execute("UPDATE users SET failed = 0, locked_until = 0 WHERE name = ?", (name,))
        return Role.named(row[0])

    def _matches(self, stored: str | None, secret: str) -> bool:
        try:
            return bool(self.hasher.verify(stored or self._dummy, secret)) and stored is not None
        except (VerificationError, InvalidHashError):
            return False

    def _failed(self, name: str, failed: int, now: float) -> None:
        locked = 0.0
        if failed >= FREE_FAILURES:
            locked = now + min(LONGEST_LOCKOUT, FIRST_LOCKOUT * 2 ** (failed - FREE_FAILURES))
        with self._tx() as db:
            db.execute(
                "UPDATE users SET failed = ?, locked_until = ? WHERE name = ?",
                (failed, locked, name),
            )

    # Sessions --------------------------------------------------------------------------------

    def open_session(self, name: str) -> tuple[str, str]:
        """A new session of `name`: (its secret id for the cookie, its CSRF token)."""
        secret, csrf = secrets.token_urlsafe(32), secrets.token_urlsafe(24)
        now = self.clock()
        with self._tx() as db:
            self._require_user(db, name)
            db.execute(
                "INSERT INTO sessions (id, user, csrf, created, last_seen) VALUES (?, ?, ?, ?, ?)",
                (digest(secret), name, csrf, now, now),
            )
        return secret, csrf

    def session(self, secret: str, *, touch: bool = True) -> Identity | None:
        """The session's identity, if it lives. `touch=False` looks without counting as use
        (an open socket's re-checks must not keep an unattended tablet signed in)."""
        sid = digest(secret)
        now = self.clock()
        with self._lock:
            row = self._db.execute(
                "SELECT s.user, u.role, s.csrf, s.created, s.last_seen FROM sessions s "
                "JOIN users u ON u.name = s.user WHERE s.id = ?",
                (sid,),
            ).fetchone()
        if row is None:
            return None
        last = max(row[4], self._touched.get(sid, 0.0))
        if session_expired(row[3], last, now, self.idle, self.absolute):
            self.close_session(sid, "expired")
            return None
        if not touch:
            return Identity(row[0], Role.named(row[1]), "session", session=sid, csrf=row[2])
        self._touched[sid] = now
        if now - row[4] > TOUCH_EVERY:
            with self._tx() as db:
                db.execute("UPDATE sessions SET last_seen = ? WHERE id = ?", (now, sid))
        return Identity(row[0], Role.named(row[1]), "session", session=sid, csrf=row[2])

    def close_session(self, sid: str, why: str = "signed_out") -> None:
        with self._tx() as db:
            self._end(db, [sid], why)

    def end_every_session(self, why: str) -> int:
        """Every user signed out (how many sessions ended)."""
        with self._tx() as db:
            ended = [r[0] for r in db.execute("SELECT id FROM sessions")]
            self._end(db, ended, why)
        return len(ended)

    def _end_sessions(self, db: sqlite3.Connection, name: str, why: str) -> None:
        ended = [r[0] for r in db.execute("SELECT id FROM sessions WHERE user = ?", (name,))]
        self._end(db, ended, why)

    def _end(self, db: sqlite3.Connection, sids: list[str], why: str) -> None:
        """End sessions, remembering why for as long as their cookies could be shown (the
        sign-in screen says it: expired, signed out, a new role…)."""
        now = self.clock()
        for sid in sids:
            self._touched.pop(sid, None)
            db.execute("DELETE FROM sessions WHERE id = ?", (sid,))
            db.execute(
                "INSERT OR REPLACE INTO ended_sessions (id, why, at) VALUES (?, ?, ?)",
                (sid, why, now),
            )
        db.execute("DELETE FROM ended_sessions WHERE at < ?", (now - self.absolute,))

    def ended(self, secret: str) -> str | None:
        """Why the session of this cookie ended, if it did lately (None: never known, or
        long ago)."""
        with self._lock:
            row = self._db.execute(
                "SELECT why FROM ended_sessions WHERE id = ?", (digest(secret),)
            ).fetchone()
        return None if row is None else str(row[0])

    # API tokens ------------------------------------------------------------------------------

    def create_token(self, name: str, role: Role) -> str:
        """A new token for scripts; only its digest is kept, so it is shown this once."""
        # ASCII: the name travels in a header to the services (as the acting user).
        if not name or len(name) > 64 or not (name.isascii() and name.isprintable()):
            raise InvalidValue("a token's name has 1 to 64 printable ASCII characters")
        secret = TOKEN_PREFIX + secrets.token_urlsafe(32)
        with self._tx() as db:
            db.execute(
                "INSERT INTO tokens (id, digest, name, role, created) VALUES (?, ?, ?, ?, ?)",
                (secrets.token_hex(6), digest(secret), name, role.name, self.clock()),
            )
        return secret

    def token(self, secret: str) -> Identity | None:
        with self._lock:
            row = self._db.execute(
                "SELECT id, name, role, last_used FROM tokens WHERE digest = ?", (digest(secret),)
            ).fetchone()
        if row is None:
            return None
        now = self.clock()
        if row[3] is None or now - row[3] > TOUCH_EVERY:
            with self._tx() as db:
                db.execute("UPDATE tokens SET last_used = ? WHERE id = ?", (now, row[0]))
        return Identity(f"token:{row[1]}", Role.named(row[2]), "token", token=row[0])

    def tokens(self) -> list[TokenInfo]:
        with self._lock:
            rows = self._db.execute(
                "SELECT id, name, role, created, last_used FROM tokens ORDER BY created"
            ).fetchall()
        return [TokenInfo(*r) for r in rows]

    def revoke_token(self, token_id: str) -> None:
        with self._tx() as db:
            if db.execute("DELETE FROM tokens WHERE id = ?", (token_id,)).rowcount == 0:
                raise NotFound(f"no token {token_id!r}", code="unknown_token")
