"""HTTPS for the UI's port and the jog socket: the runtime's own certificate authority and a
server certificate from it for this computer's names and addresses (made in the data
directory at the first start with TLS, the server certificate made again when a name or
address is new or it nears its end), or the site's own certificate and key.

A tablet trusts the authority once (its fingerprint is printed at start and shown on the
set-up screen); the server certificate can then change without asking it again. The
authority may sign only server certificates, and only for the names this computer had when
it was made (localhost, hostname, hostname.local, its configured names and their
subdomains), the loopback addresses and the networks of its interfaces then: installed on
a tablet, a leaked key of it could stand in for nothing but this computer's names and its
networks' addresses."""

from __future__ import annotations

import base64
import datetime
import hashlib
import ipaddress
import logging
import os
import socket
import ssl
from dataclasses import dataclass
from pathlib import Path

import idna
import ifaddr
from cryptography import x509
from cryptography.exceptions import InvalidSignature, UnsupportedAlgorithm
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from openpendant.runtime.kit.settings import RuntimeSettings, is_loopback

log = logging.getLogger(__name__)

TLS_DIR = "tls"
CA_CERT = "ca.pem"
CA_KEY = "ca-key.pem"
SERVER_CERT = "server.pem"  # the server's certificate, then the authority's
SERVER_KEY = "server-key.pem"
# Where a tablet downloads the authority to trust it (on the HTTPS port and the redirect port).
CA_DOWNLOAD = "/openpendant-ca.crt"

CA_DAYS = 3650
# At most 825 days: Apple's devices refuse a longer-lived server certificate from any root.
SERVER_DAYS = 800
RENEW_BEFORE_DAYS = 60

IPAddress = ipaddress.IPv4Address | ipaddress.IPv6Address
LOOPBACK_NETWORKS = [ipaddress.ip_network("127.0.0.0/8"), ipaddress.ip_network("::1/128")]
IPNetwork = ipaddress.IPv4Network | ipaddress.IPv6Network


class TlsError(RuntimeError):
    """A certificate or key that cannot be used, with what to do."""


@dataclass(frozen=True)
class TlsFiles:
    cert: Path  # the server's certificate and its chain (PEM)
    key: Path
    ca: Path | None  # the runtime's own authority (None: the site's certificate)

    def server_context(self) -> ssl.SSLContext:
        context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
        context.minimum_version = ssl.TLSVersion.TLSv1_2
        context.load_cert_chain(self.cert, self.key)
        return context

    def trusted(self) -> x509.Certificate:
        """What a tablet trusts: the runtime's authority, or the site's certificate."""
        return x509.load_pem_x509_certificate((self.ca or self.cert).read_bytes())

    def fingerprint(self) -> str:
        """SHA-256 of the trusted certificate, as browsers and phones show it."""
        digest = self.trusted().fingerprint(hashes.SHA256())
        return ":".join(f"{b:02X}" for b in digest)

    def spki_pin(self) -> str:
        """base64 SHA-256 of the trusted certificate's public key (Chromium's
        --ignore-certificate-errors-spki-list, HPKP-style pins)."""
        public = (
            self.trusted()
            .public_key()
            .public_bytes(
                serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo
            )
        )
        return base64.b64encode(hashlib.sha256(public).digest()).decode()


def probe_context() -> ssl.SSLContext:
    """For the launcher's health probes of its own UI port over loopback: they carry nothing
    secret and only ask whether it answers, so the certificate (a site's may not name
    127.0.0.1) is not what they check."""
    context = ssl.create_default_context()
    context.check_hostname = False
    context.verify_mode = ssl.CERT_NONE
    return context


def tls_files(settings: RuntimeSettings) -> TlsFiles | None:
    """Where this runtime's certificate and key are (None: TLS is off). Made by `prepare`."""
    tls = settings.tls
    if not tls.enabled:
        return None
    if tls.cert_file is not None and tls.key_file is not None:
        return TlsFiles(tls.cert_file, tls.key_file, None)
    folder = settings.data_dir / TLS_DIR
    return TlsFiles(folder / SERVER_CERT, folder / SERVER_KEY, folder / CA_CERT)


def prepare(settings: RuntimeSettings) -> TlsFiles | None:
    """The certificate and key the servers will use, made or renewed where they are ours;
    a site certificate that cannot be loaded is refused here, before any service starts."""
    files = tls_files(settings)
    if files is None:
        return None
    if files.ca is not None:
        names, addresses = host_names(settings)
        try:
            _own_certificates(files, names, addresses)
        except (OSError, ValueError, TypeError, UnsupportedAlgorithm) as exc:
            raise TlsError(
                f"cannot make the HTTPS certificates in {files.ca.parent}: {exc}"
            ) from exc
    try:
        files.server_context()
    except (OSError, ssl.SSLError) as exc:
        raise TlsError(
            f"cannot use the certificate {files.cert} with the key {files.key}: {exc}"
        ) from exc
    return files


def lan_download(settings: RuntimeSettings) -> str | None:
    """Where a tablet on the LAN fetches the authority (a QR code's address when the UI is
    opened on this computer itself): an address of the interface of the default route first
    (not a bridge or the robot's own network), by plain HTTP where the redirect port is fixed
    (the fingerprint tells a tablet it is the right one), else on the HTTPS port."""
    if not _unspecified(settings.host):
        return None if is_loopback(settings.host) else _download_url(settings, settings.host)
    routed = _default_route_interface()
    candidates = [
        (name != routed, interface.version, str(interface.ip))
        for name, interface in _named_interfaces()
        if not (interface.ip.is_loopback or interface.ip.is_link_local)
    ]
    return _download_url(settings, min(candidates)[2]) if candidates else None


def _download_url(settings: RuntimeSettings, address: str) -> str:
    host = f"[{address}]" if ":" in address else address
    if settings.tls.redirect_port:
        return f"http://{host}:{settings.tls.redirect_port}{CA_DOWNLOAD}"
    return f"https://{host}:{settings.port}{CA_DOWNLOAD}"


def _unspecified(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_unspecified
    except ValueError:
        return host == ""


def _default_route_interface() -> str | None:
    """The interface of the IPv4 default route (/proc/net/route), if there is one."""
    try:
        rows = Path("/proc/net/route").read_text().splitlines()[1:]
    except OSError:
        return None
    for row in rows:
        fields = row.split()
        if len(fields) > 1 and fields[1] == "00000000":
            return fields[0]
    return None


def host_names(settings: RuntimeSettings) -> tuple[list[str], list[IPAddress]]:
    """The names and addresses a browser may use for this computer's UI."""
    hostname = socket.gethostname().lower()
    names = ["localhost", hostname]
    if "." not in hostname:
        names.append(f"{hostname}.local")
    names += [n.lower() for n in (*settings.allowed_hosts, *settings.tls.names)]
    names = [dns for dns in (_dns_name(n) for n in names) if dns]
    addresses: list[IPAddress] = [ipaddress.ip_address("127.0.0.1"), ipaddress.ip_address("::1")]
    try:
        bound = ipaddress.ip_address(settings.host)
    except ValueError:
        bound = None
    if bound is None or bound.is_unspecified:
        addresses += _interface_addresses()
    else:
        addresses.append(bound)
    return list(dict.fromkeys(names)), list(dict.fromkeys(addresses))


def _dns_name(name: str) -> str | None:
    """A name as a certificate writes it (IDNA 2008 with UTS 46, as browsers write one with
    letters beyond ASCII), or None (with a warning) for one that is not a host name: an
    empty name would permit every name, and an address is not a name."""
    try:
        ipaddress.ip_address(name)
    except ValueError:
        pass
    else:
        log.warning("%r is an address, not a name: it is covered as an address", name)
        return None
    try:
        return idna.encode(name, uts46=True).decode("ascii") if name else None
    except idna.IDNAError:
        log.warning("%r is not a host name: no certificate is made for it", name)
        return None


Interface = ipaddress.IPv4Interface | ipaddress.IPv6Interface
# A network wider than this is not an interface's own (a /0 from an odd driver): the
# authority is not made to vouch for it.
WIDEST_PREFIX = {4: 8, 6: 48}


def _named_interfaces() -> list[tuple[str, Interface]]:
    """This computer's interfaces' addresses, each with its network (a link-local IPv6
    address needs its interface named in a URL: not a browser's)."""
    found: list[tuple[str, Interface]] = []
    try:
        adapters = ifaddr.get_adapters()
    except (OSError, ValueError, AssertionError) as exc:
        log.warning("cannot list this computer's addresses: %s", exc)
        return found
    for adapter in adapters:
        for ip in adapter.ips:
            text = ip.ip if isinstance(ip.ip, str) else ip.ip[0]
            try:
                interface = ipaddress.ip_interface(f"{text}/{ip.network_prefix}")
            except ValueError:
                continue
            if not (interface.version == 6 and interface.is_link_local):
                found.append((str(adapter.name), interface))
    return found


def _interfaces() -> list[Interface]:
    return [interface for _, interface in _named_interfaces()]


def _own_networks() -> list[IPNetwork]:
    """What the authority may vouch for besides loopback: its interfaces' networks, none
    wider than WIDEST_PREFIX."""
    return [
        i.network if i.network.prefixlen >= WIDEST_PREFIX[i.version] else ipaddress.ip_network(i.ip)
        for i in _interfaces()
        if not i.ip.is_loopback
    ]


def _interface_addresses() -> list[IPAddress]:
    return [interface.ip for interface in _interfaces()]


def permitted(name: str | IPAddress, ca: x509.Certificate) -> bool:
    try:
        constraints = ca.extensions.get_extension_for_class(x509.NameConstraints).value
    except x509.ExtensionNotFound:
        return True
    for subtree in constraints.permitted_subtrees or []:
        value = subtree.value
        if isinstance(name, str) and isinstance(subtree, x509.DNSName):
            if name == value or name.endswith(f".{value}"):
                return True
        elif (
            not isinstance(name, str)
            and isinstance(value, ipaddress.IPv4Network | ipaddress.IPv6Network)
            and name.version == value.version
            and name in value
        ):
            return True
    return False


def _own_certificates(files: TlsFiles, names: list[str], addresses: list[IPAddress]) -> None:
    assert files.ca is not None
    folder = files.ca.parent
    folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    folder.chmod(0o700)
    ca_key_path = folder / CA_KEY
    authority = _authority(files.ca, ca_key_path)
    if authority is None:
        networks = [*LOOPBACK_NETWORKS, *_own_networks()]
        ca_key, ca = _make_authority(names, networks)
        _write_key(ca_key_path, ca_key)
        _write(files.ca, ca.public_bytes(serialization.Encoding.PEM))
        log.info("made a certificate authority in %s", folder)
    else:
        ca_key, ca = authority
    covered = [n for n in (*names, *addresses) if permitted(n, ca)]
    left_out = [str(n) for n in (*names, *addresses) if n not in covered]
    if left_out:
        log.warning(
            "the certificate authority was made before %s was this computer's: a browser "
            "using it will warn (remove %s to make a new authority, which every tablet must "
            "trust again)",
            ", ".join(left_out),
            folder,
        )
    if _current(files, ca, covered):
        return
    key = ec.generate_private_key(ec.SECP256R1())
    leaf = _make_server(key, ca_key, ca, covered)
    _write_key(files.key, key)
    _write(
        files.cert,
        leaf.public_bytes(serialization.Encoding.PEM) + ca.public_bytes(serialization.Encoding.PEM),
    )
    log.info("made a server certificate for %s", ", ".join(str(n) for n in covered))


def _authority(cert: Path, key: Path) -> tuple[ec.EllipticCurvePrivateKey, x509.Certificate] | None:
    """The authority on disk; None when there is none yet (or only its key: a start cut off
    while making it, before any tablet could trust it). One that cannot be used is never
    replaced here: tablets trust it, so a TlsError says what to do."""
    if not cert.exists():
        return None
    try:
        certificate = x509.load_pem_x509_certificate(cert.read_bytes())
        loaded = serialization.load_pem_private_key(key.read_bytes(), password=None)
    except (OSError, ValueError, TypeError, UnsupportedAlgorithm) as exc:
        raise TlsError(_unusable(cert.parent, str(exc))) from exc
    if not isinstance(loaded, ec.EllipticCurvePrivateKey) or not _pair(certificate, loaded):
        raise TlsError(_unusable(cert.parent, "its key is not its certificate's"))
    return loaded, certificate


def _unusable(folder: Path, why: str) -> str:
    return (
        f"the HTTPS certificate authority in {folder} cannot be used ({why}). Restore it "
        f"from a backup (openpendant restore), or move {folder} aside to make a new one, "
        "which every tablet must then trust again"
    )


def _pair(certificate: x509.Certificate, key: ec.EllipticCurvePrivateKey) -> bool:
    der = (serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo)
    return certificate.public_key().public_bytes(*der) == key.public_key().public_bytes(*der)


def _current(files: TlsFiles, ca: x509.Certificate, wanted: list[str | IPAddress]) -> bool:
    """Whether the server certificate on disk is the authority's, covers `wanted` and has
    more than RENEW_BEFORE_DAYS left."""
    if not files.cert.is_file() or not files.key.is_file():
        return False
    try:
        leaf = x509.load_pem_x509_certificates(files.cert.read_bytes())[0]
        leaf.verify_directly_issued_by(ca)
        san = leaf.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
        key = serialization.load_pem_private_key(files.key.read_bytes(), password=None)
    except (OSError, ValueError, TypeError, x509.ExtensionNotFound, InvalidSignature):
        return False
    if not isinstance(key, ec.EllipticCurvePrivateKey) or not _pair(leaf, key):
        return False  # a half-written pair (a power cut between the two files)
    have: set[str | IPAddress] = set(san.get_values_for_type(x509.DNSName))
    have |= {
        a
        for a in san.get_values_for_type(x509.IPAddress)
        if isinstance(a, ipaddress.IPv4Address | ipaddress.IPv6Address)
    }
    left = leaf.not_valid_after_utc - _now()
    return set(wanted) <= have and left > datetime.timedelta(days=RENEW_BEFORE_DAYS)


def _now() -> datetime.datetime:
    return datetime.datetime.now(datetime.UTC)


def _key_usage(*, signs_certificates: bool) -> x509.KeyUsage:
    """An authority's key signs certificates (and their revocations); a server's, handshakes."""
    return x509.KeyUsage(
        digital_signature=not signs_certificates,
        content_commitment=False,
        key_encipherment=False,
        data_encipherment=False,
        key_agreement=False,
        key_cert_sign=signs_certificates,
        crl_sign=signs_certificates,
        encipher_only=False,
        decipher_only=False,
    )


def _make_authority(
    names: list[str], networks: list[IPNetwork]
) -> tuple[ec.EllipticCurvePrivateKey, x509.Certificate]:
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name(
        [
            x509.NameAttribute(NameOID.ORGANIZATION_NAME, "OpenPendant"),
            x509.NameAttribute(NameOID.COMMON_NAME, f"OpenPendant CA {socket.gethostname()}"[:64]),
        ]
    )
    permitted: list[x509.GeneralName] = [x509.DNSName(n) for n in sorted({"localhost", *names})]
    permitted += [x509.IPAddress(n) for n in dict.fromkeys(networks)]
    start = _now() - datetime.timedelta(days=1)
    certificate = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(start)
        .not_valid_after(start + datetime.timedelta(days=CA_DAYS))
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(_key_usage(signs_certificates=True), critical=True)
        .add_extension(
            x509.NameConstraints(permitted_subtrees=permitted, excluded_subtrees=None),
            critical=True,
        )
        # Server certificates only: nothing it signs is good for mail or code.
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
        .sign(key, hashes.SHA256())
    )
    return key, certificate


def _make_server(
    key: ec.EllipticCurvePrivateKey,
    ca_key: ec.EllipticCurvePrivateKey,
    ca: x509.Certificate,
    names: list[str | IPAddress],
) -> x509.Certificate:
    alternative: list[x509.GeneralName] = [
        x509.DNSName(n) if isinstance(n, str) else x509.IPAddress(n) for n in names
    ]
    start = _now() - datetime.timedelta(days=1)
    return (
        x509.CertificateBuilder()
        .subject_name(
            x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, socket.gethostname()[:64])])
        )
        .issuer_name(ca.subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(start)
        .not_valid_after(start + datetime.timedelta(days=SERVER_DAYS))
        .add_extension(x509.SubjectAlternativeName(alternative), critical=False)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(_key_usage(signs_certificates=False), critical=True)
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
        .add_extension(
            x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()),
            critical=False,
        )
        .sign(ca_key, hashes.SHA256())
    )


def _write_key(path: Path, key: ec.EllipticCurvePrivateKey) -> None:
    _write(
        path,
        key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        ),
    )


def _write(path: Path, data: bytes) -> None:
    """Written whole or not at all (a power cut leaves the old file), readable by its owner."""
    partial = path.with_name(path.name + ".partial")
    descriptor = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "wb") as out:
        out.write(data)
        out.flush()
        os.fsync(out.fileno())
    os.replace(partial, path)
