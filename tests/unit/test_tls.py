"""HTTPS on its own: the runtime's certificate authority and server certificate
(runtime/kit/tls.py), checked by OpenSSL as a client would; the plain port's redirect
(runtime/kit/https_redirect.py); two servers of one process, one over TLS (kit/serve.py)."""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import logging
import signal
import socket
import ssl
import subprocess
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest
from cryptography import x509
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric import ec
from fastapi.testclient import TestClient
from pydantic import ValidationError
from websockets.asyncio.client import connect as ws_connect

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.setup import auth_path
from openpendant.runtime.auth.store import AuthStore
from openpendant.runtime.bench.harness.processes import wait_for
from openpendant.runtime.kit import tls
from openpendant.runtime.kit.https_redirect import HttpsRedirect
from openpendant.runtime.kit.serve import listening_socket
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.kit.web_guard import WebPolicy
from openpendant.runtime.launcher.doctor import https
from openpendant.runtime.launcher.run import sessions_follow_transport
from tests.support.two_listeners import NO_CONTEXT_EXIT

REPOSITORY = Path(__file__).resolve().parents[2]


def settings(data_dir: Path, **tls_options: object) -> RuntimeSettings:
    return RuntimeSettings(data_dir=data_dir, tls={"enabled": True, **tls_options})


@contextlib.contextmanager
def tls_server(files: tls.TlsFiles) -> Iterator[int]:
    """A bare TLS server with the runtime's context that completes one handshake at a time."""
    context = files.server_context()
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(5)

    def serve() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            with (
                contextlib.suppress(OSError, ssl.SSLError),
                context.wrap_socket(conn, server_side=True) as wrapped,
            ):
                wrapped.recv(1)

    threading.Thread(target=serve, daemon=True).start()
    try:
        yield server.getsockname()[1]
    finally:
        server.close()


def handshake(port: int, ca: Path, name: str) -> str:
    """A client that trusts only `ca`, connecting to 127.0.0.1 as `name`: its TLS version."""
    client = ssl.create_default_context(cafile=str(ca))
    with (
        socket.create_connection(("127.0.0.1", port), timeout=5) as raw,
        client.wrap_socket(raw, server_hostname=name) as wrapped,
    ):
        wrapped.send(b"x")
        return str(wrapped.version())


def test_the_first_start_makes_an_authority_and_a_certificate_a_client_trusting_it_accepts(
    tmp_path: Path,
) -> None:
    files = tls.prepare(settings(tmp_path, names=["pendant.cell4.example"]))
    assert files is not None and files.ca is not None
    folder = tmp_path / tls.TLS_DIR
    assert folder.stat().st_mode & 0o777 == 0o700
    for made in folder.iterdir():
        assert made.stat().st_mode & 0o777 == 0o600, made
    with tls_server(files) as port:
        for name in ("127.0.0.1", "localhost", "pendant.cell4.example", socket.gethostname()):
            assert handshake(port, files.ca, name) in ("TLSv1.2", "TLSv1.3")
        with pytest.raises(ssl.SSLCertVerificationError):
            handshake(port, files.ca, "elsewhere.example")
    # TLS 1.1 and older are refused.
    assert files.server_context().minimum_version == ssl.TLSVersion.TLSv1_2
    fingerprint = files.fingerprint()
    assert len(fingerprint.split(":")) == 32
    assert len(files.spki_pin()) == 44  # base64 of 32 bytes


def test_the_authority_is_kept_and_the_certificate_made_again_for_a_new_name(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    first = settings(tmp_path, names=["pendant.cell4.example"])
    files = tls.prepare(first)
    assert files is not None and files.ca is not None
    authority, server = files.ca.read_bytes(), files.cert.read_bytes()
    tls.prepare(first)
    assert (files.ca.read_bytes(), files.cert.read_bytes()) == (authority, server)
    # A name below one it was made for, and the LAN's addresses (the UI on every interface).
    wider = settings(tmp_path, names=["pendant.cell4.example", "arm.pendant.cell4.example"])
    tls.prepare(wider.model_copy(update={"host": "0.0.0.0"}))
    assert files.ca.read_bytes() == authority  # a tablet that trusts it keeps trusting
    assert files.cert.read_bytes() != server
    lan = [str(i.ip) for i in tls._interfaces() if not i.ip.is_loopback]
    with tls_server(files) as port:
        for name in ("arm.pendant.cell4.example", *lan):
            handshake(port, files.ca, name)
    # A name the authority was not made for is left out, and the log says how to get it.
    with caplog.at_level(logging.WARNING):
        tls.prepare(settings(tmp_path, names=["pendant.cell4.example", "cell-7.local"]))
    assert "cell-7.local" in caplog.text and "new authority" in caplog.text
    assert files.ca.read_bytes() == authority


def test_a_half_written_pair_is_mended_and_a_trusted_authority_never_replaced(
    tmp_path: Path,
) -> None:
    """A power cut between a key and its certificate: the next start mends what no tablet
    trusts yet, and stops with what to do where an authority tablets trust is damaged."""
    files = tls.prepare(settings(tmp_path))
    assert files is not None and files.ca is not None
    authority = files.ca.read_bytes()
    tls._write_key(files.key, ec.generate_private_key(ec.SECP256R1()))
    mended = tls.prepare(settings(tmp_path))
    assert mended is not None and files.ca.read_bytes() == authority
    mended.server_context()  # the key is the certificate's again
    ca_key = files.ca.parent / tls.CA_KEY
    for damage in (
        lambda: tls._write_key(ca_key, ec.generate_private_key(ec.SECP256R1())),
        lambda: ca_key.write_text("damaged"),
        ca_key.unlink,
    ):
        damage()
        with pytest.raises(tls.TlsError, match=r"Restore it from a backup"):
            tls.prepare(settings(tmp_path))
        assert files.ca.read_bytes() == authority  # never replaced behind the tablets' back
    # Only the key of an authority never finished (no certificate yet): made anew.
    files.ca.unlink()
    tls._write_key(ca_key, ec.generate_private_key(ec.SECP256R1()))
    anew = tls.prepare(settings(tmp_path))
    assert anew is not None and files.ca.read_bytes() != authority
    with tls_server(anew) as port:
        handshake(port, files.ca, "localhost")


def test_names_are_written_as_browsers_write_them() -> None:
    # Python's own IDNA 2003 codec agrees where the two standards do (no ß, ς, ZWJ).
    assert tls._dns_name("Prüfstand.example") == "prüfstand.example".encode("idna").decode()
    assert tls._dns_name("straße.example") == "xn--strae-oqa.example"  # IDNA 2008, not 2003
    for bad in ("", "192.168.1.5", "pendant:8080", "a b"):
        assert not tls._dns_name(bad), bad


def test_the_lan_address_for_a_tablet_is_the_default_routes(tmp_path: Path) -> None:
    lan = settings(tmp_path, redirect_port=8080).model_copy(update={"host": "0.0.0.0"})
    url = tls.lan_download(lan)
    routed = tls._default_route_interface()
    if routed is not None:
        ours = [str(i.ip) for n, i in tls._named_interfaces() if n == routed]
        assert url is not None and any(f"//{a}:8080/" in url or f"[{a}]" in url for a in ours)
    assert tls.lan_download(settings(tmp_path)) is None  # the UI on loopback only
    one = settings(tmp_path).model_copy(update={"host": "192.0.2.7", "port": 8443})
    assert tls.lan_download(one) == "https://192.0.2.7:8443/openpendant-ca.crt"


def test_a_certificate_near_its_end_is_made_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    files = tls.prepare(settings(tmp_path))
    assert files is not None
    before = files.cert.read_bytes()
    monkeypatch.setattr(tls, "RENEW_BEFORE_DAYS", tls.SERVER_DAYS + 1)
    tls.prepare(settings(tmp_path))
    assert files.cert.read_bytes() != before


def test_the_authority_cannot_vouch_for_another_site(tmp_path: Path) -> None:
    """Installed on a tablet, its key (were it stolen) could not stand in for a bank."""
    files = tls.prepare(settings(tmp_path))
    assert files is not None and files.ca is not None
    loaded = serialization.load_pem_private_key(
        (files.ca.parent / tls.CA_KEY).read_bytes(), password=None
    )
    assert isinstance(loaded, ec.EllipticCurvePrivateKey)
    authority = x509.load_pem_x509_certificate(files.ca.read_bytes())
    key = ec.generate_private_key(ec.SECP256R1())
    forged = tls._make_server(key, loaded, authority, ["bank.example"])
    folder = tmp_path / "forged"
    folder.mkdir()
    cert, key_file = folder / "cert.pem", folder / "key.pem"
    cert.write_bytes(forged.public_bytes(serialization.Encoding.PEM) + files.ca.read_bytes())
    tls._write_key(key_file, key)
    with (
        tls_server(tls.TlsFiles(cert, key_file, None)) as port,
        pytest.raises(ssl.SSLCertVerificationError, match=r"(?i)name constraint|permitted"),
    ):
        handshake(port, files.ca, "bank.example")
    # Nor for another cell's name on the same network, nor an address of another network.
    for other in ("other-cell.local", ipaddress.ip_address("10.99.0.1")):
        forged = tls._make_server(key, loaded, authority, [other])
        cert.write_bytes(forged.public_bytes(serialization.Encoding.PEM) + files.ca.read_bytes())
        with (
            tls_server(tls.TlsFiles(cert, key_file, None)) as port,
            pytest.raises(ssl.SSLCertVerificationError),
        ):
            handshake(port, files.ca, str(other))


def test_the_sites_own_certificate_is_used_as_given_and_a_wrong_key_refused(
    tmp_path: Path,
) -> None:
    own = tls.prepare(settings(tmp_path / "made"))
    assert own is not None
    site = settings(tmp_path / "site", cert_file=own.cert, key_file=own.key)
    files = tls.prepare(site)
    assert files is not None and files.ca is None and files.cert == own.cert
    assert not (tmp_path / "site" / tls.TLS_DIR).exists()
    wrong = tmp_path / "wrong-key.pem"
    tls._write_key(wrong, ec.generate_private_key(ec.SECP256R1()))
    with pytest.raises(tls.TlsError, match=r"wrong-key\.pem"):
        tls.prepare(settings(tmp_path / "site", cert_file=own.cert, key_file=wrong))
    with pytest.raises(ValidationError, match="both cert_file and key_file"):
        settings(tmp_path, cert_file=own.cert)


def test_plain_http_is_sent_on_to_https_but_for_the_authority(tmp_path: Path) -> None:
    ca = tmp_path / "ca.pem"
    ca.write_text("-----BEGIN CERTIFICATE-----\n")
    client = TestClient(
        HttpsRedirect(WebPolicy(ui_port=8443, scheme="https"), 8443, ca),
        base_url="http://127.0.0.1:8080",
        follow_redirects=False,
    )
    moved = client.post("/api/auth/login?next=%2Fjog", json={})
    assert moved.status_code == 308  # the method and body are kept
    assert moved.headers["location"] == "https://127.0.0.1:8443/api/auth/login?next=%2Fjog"
    v6 = client.get("/", headers={"host": "[::1]:8080"})
    assert v6.headers["location"] == "https://[::1]:8443/"
    fetched = client.get(tls.CA_DOWNLOAD)
    assert fetched.status_code == 200 and fetched.content == ca.read_bytes()
    assert fetched.headers["content-type"] == "application/x-x509-ca-cert"
    rebound = client.get("/", headers={"host": "attacker.example"})
    assert rebound.status_code == 400 and "location" not in rebound.headers
    standard = TestClient(
        HttpsRedirect(WebPolicy(ui_port=443, scheme="https"), 443, None),
        base_url="http://127.0.0.1",
        follow_redirects=False,
    )
    assert standard.get("/x").headers["location"] == "https://127.0.0.1/x"
    assert standard.get(tls.CA_DOWNLOAD).status_code == 308  # no authority of its own


def test_an_https_ui_accepts_only_its_https_origin() -> None:
    policy = WebPolicy(ui_port=8443, scheme="https", jog_port=8444)
    host = "127.0.0.1:8443"
    assert policy.check_origin("https://127.0.0.1:8443", host) is None
    assert policy.check_origin("http://127.0.0.1:8443", host) is not None
    assert "ws://" not in policy.content_security_policy(host)
    assert "wss://127.0.0.1:*" in policy.content_security_policy(host)


@dataclass
class TwoListeners:
    process: subprocess.Popen[bytes]
    plain_port: int
    secure_port: int


@contextlib.contextmanager
def two_listeners(mode: str, files: tls.TlsFiles, journal: Path) -> Iterator[TwoListeners]:
    """tests/support/two_listeners.py in a process of its own, on two sockets made here."""
    plain, secure = listening_socket("127.0.0.1", 0), listening_socket("127.0.0.1", 0)
    argv = [sys.executable, "-m", "tests.support.two_listeners", mode]
    argv += [str(plain.fileno()), str(secure.fileno()), str(files.cert), str(files.key)]
    process = subprocess.Popen(
        [*argv, str(journal)], pass_fds=(plain.fileno(), secure.fileno()), cwd=REPOSITORY
    )
    try:
        yield TwoListeners(process, plain.getsockname()[1], secure.getsockname()[1])
    finally:
        plain.close()
        secure.close()
        if process.poll() is None:
            process.kill()
        process.wait()


def test_a_second_listener_over_tls_serves_once_the_first_has_started_and_closes_first(
    tmp_path: Path,
) -> None:
    """The jog service's shape: its internal port plain and its public one over TLS, one app
    whose start-up (lifespan) runs once. On SIGTERM the public socket's connections close
    (a held jog's socket halts its robot then) before the app shuts down."""
    files = tls.prepare(settings(tmp_path))
    assert files is not None and files.ca is not None
    journal = tmp_path / "journal"
    context = ssl.create_default_context(cafile=str(files.ca))
    with two_listeners("held", files, journal) as served:
        url = f"https://127.0.0.1:{served.secure_port}/ready"
        with httpx.Client(verify=context, timeout=5) as client:
            answer = wait_for(lambda: client.get(url), 30, what="the TLS listener")
        assert answer.json() == {"ready": "yes"}
        with httpx.Client(timeout=5) as client:
            inside = f"http://127.0.0.1:{served.plain_port}/ready"
            answer = wait_for(lambda: client.get(inside), 5)
        assert answer.json() == {"ready": "yes"}

        async def hold_then_stop() -> int:
            held_url = f"wss://127.0.0.1:{served.secure_port}/held"
            async with ws_connect(held_url, ssl=context, open_timeout=5) as holding:
                await holding.send("holding")
                served.process.send_signal(signal.SIGTERM)
                return await asyncio.to_thread(served.process.wait, 15)

        code = asyncio.run(hold_then_stop())
    # uvicorn ends the process with the signal it handled, once both servers are done.
    assert code in (0, -signal.SIGTERM)
    assert journal.read_text().splitlines() == ["socket closed", "app shut down"]


def test_a_second_listener_that_cannot_start_stops_the_first_in_order(tmp_path: Path) -> None:
    """Its TLS context failing (a certificate gone): the process ends with an error (the
    launcher restarts it), after the app's own shutdown, not cancelled half-way."""
    files = tls.prepare(settings(tmp_path))
    assert files is not None
    journal = tmp_path / "journal"
    with two_listeners("no_context", files, journal) as served:
        assert served.process.wait(30) == NO_CONTEXT_EXIT
    assert journal.read_text() == "app shut down\n"


def test_the_doctor_says_what_https_needs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    lan = RuntimeSettings(data_dir=tmp_path, host="0.0.0.0")
    [clear] = https(lan)
    assert clear.verdict == "warn" and "tls" in clear.todo
    assert list(https(RuntimeSettings(data_dir=tmp_path))) == []  # loopback only: fine
    [first] = https(settings(tmp_path))
    assert first.verdict == "ok" and "next start" in first.what
    files = tls.prepare(settings(tmp_path))
    assert files is not None
    [ready] = https(settings(tmp_path))
    assert ready.verdict == "ok" and files.fingerprint() in ready.what
    monkeypatch.setattr(tls, "SERVER_DAYS", 20)
    monkeypatch.setattr(tls, "RENEW_BEFORE_DAYS", 10**4)  # made again, with 20 days
    tls.prepare(settings(tmp_path))
    [ending] = https(settings(tmp_path))
    assert ending.verdict == "warn" and "restart" in ending.todo
    renamed = settings(tmp_path, names=["cell-7.example"])
    reach = [f for f in https(renamed) if "made before" in f.what]
    assert len(reach) == 1 and reach[0].verdict == "warn" and "cell-7.example" in reach[0].what


def test_sessions_signed_in_over_plain_http_end_when_https_is_turned_on(tmp_path: Path) -> None:
    store = AuthStore(auth_path(tmp_path))
    try:
        store.create_user("ada", "correct horse battery", Role.admin, first=True)
        in_clear, _ = store.open_session("ada")
    finally:
        store.close()
    files = tls.prepare(settings(tmp_path))
    sessions_follow_transport(settings(tmp_path), None)  # still plain: nothing ends
    store = AuthStore(auth_path(tmp_path))
    try:
        assert store.session(in_clear) is not None
    finally:
        store.close()
    sessions_follow_transport(settings(tmp_path), files)
    store = AuthStore(auth_path(tmp_path))
    try:
        assert store.session(in_clear) is None
        assert store.ended(in_clear) == "secure_connection"
        secure, _ = store.open_session("ada")
    finally:
        store.close()
    sessions_follow_transport(settings(tmp_path), files)  # the next start over HTTPS keeps them
    store = AuthStore(auth_path(tmp_path))
    try:
        assert store.session(secure) is not None
    finally:
        store.close()
