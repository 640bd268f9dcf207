"""Signing in as a browser does, for tests that end the sign-in under an open socket."""

from __future__ import annotations

import httpx

from openpendant.runtime.bench.harness.processes import Runtime


def signed_in(runtime: Runtime, role: str) -> dict[str, str]:
    """A new session of the `role` user: the headers its page sends (cookie, CSRF token)."""
    name, password = runtime.user(role)
    login = httpx.post(
        f"{runtime.url}/api/auth/login", json={"user": name, "password": password}, timeout=10
    )
    login.raise_for_status()
    return {
        "Cookie": f"op_session={login.cookies['op_session']}",
        "x-csrf-token": login.json()["csrf"],
    }


def sign_out(runtime: Runtime, session: dict[str, str]) -> None:
    assert runtime.api("POST", "/auth/logout", role=None, headers=session).status_code == 204


def revoke_token(runtime: Runtime, name: str) -> None:
    """Revoked on the Users page: by an administrator, who confirms with their password."""
    admin = signed_in(runtime, "admin")
    _, password = runtime.user("admin")
    listed = runtime.api("GET", "/auth/tokens", role=None, headers=admin).json()
    token_id = next(t["id"] for t in listed if t["name"] == name)
    answer = runtime.api(
        "DELETE",
        f"/auth/tokens/{token_id}",
        role=None,
        headers=admin,
        json={"confirm_password": password},
    )
    assert answer.status_code == 204, answer.text
