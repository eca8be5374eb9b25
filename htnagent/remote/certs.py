"""Certificates for a test fleet: a self-signed root and peer certificates signed by it.

``python -m htnagent certs DIR`` writes ``root.pem`` (the root certificate every
side trusts), ``root.key`` (its key, to sign more peers later) and, for each
peer name (default ``serve`` and ``parent``), ``NAME.pem`` and ``NAME.key``.  The
peers' certificates name ``localhost``, ``127.0.0.1`` and ``::1`` (and any
``--host`` given), so that Zenoh's check of the name connected to holds.

For tests and trials only: the keys are written unencrypted, the root lives one
year, and nothing here revokes a certificate.  A real fleet's certificates come
from its own authority.
"""

from __future__ import annotations

import datetime
import ipaddress
import os
import re
from collections.abc import Sequence
from pathlib import Path

from htnagent.errors import RemoteError

try:
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID
except ImportError:
    raise RemoteError(
        "making certificates needs the cryptography package of the zenoh extra: pip install 'htnagent[zenoh]'"
    ) from None

DEFAULT_PEERS = ("serve", "parent")
DEFAULT_HOSTS = ("localhost", "127.0.0.1", "::1")
VALID_DAYS = 365
_NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")


def _name(common_name: str) -> x509.Name:
    return x509.Name(
        [
            x509.NameAttribute(NameOID.ORGANIZATION_NAME, "htnagent test fleet"),
            x509.NameAttribute(NameOID.COMMON_NAME, common_name),
        ]
    )


def _write(path: Path, data: bytes, *, secret: bool) -> None:
    # A key is readable by its owner only, from the moment it exists.
    flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC
    fd = os.open(path, flags, 0o600 if secret else 0o644)
    with os.fdopen(fd, "wb") as out:
        out.write(data)


def _key_bytes(key: ec.EllipticCurvePrivateKey) -> bytes:
    return key.private_bytes(
        serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
    )


def make_certificates(
    folder: Path, peers: Sequence[str] = DEFAULT_PEERS, hosts: Sequence[str] = DEFAULT_HOSTS
) -> list[Path]:
    """Write a root and a certificate per peer into ``folder`` (made if need be); the files written.

    Raises RemoteError for a peer name that is not a plain file name, or a folder that
    cannot be written."""
    for peer in peers:
        if not _NAME.fullmatch(peer) or peer == "root":
            raise RemoteError(f"peer name {peer!r}: letters, digits, '_', '.', '-' only, and not 'root'")
    now = datetime.datetime.now(datetime.UTC)
    until = now + datetime.timedelta(days=VALID_DAYS)
    root_key = ec.generate_private_key(ec.SECP256R1())
    root_name = _name("htnagent test root")
    root = (
        x509.CertificateBuilder()
        .subject_name(root_name)
        .issuer_name(root_name)
        .public_key(root_key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(until)
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(
            x509.KeyUsage(
                digital_signature=True,
                key_cert_sign=True,
                crl_sign=True,
                content_commitment=False,
                key_encipherment=False,
                data_encipherment=False,
                key_agreement=False,
                encipher_only=False,
                decipher_only=False,
            ),
            critical=True,
        )
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(root_key.public_key()), critical=False)
        .sign(root_key, hashes.SHA256())
    )
    names: list[x509.GeneralName] = []
    for host in hosts:
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(host)))
        except ValueError:
            names.append(x509.DNSName(host))
    try:
        folder.mkdir(parents=True, exist_ok=True)
        written = [folder / "root.pem", folder / "root.key"]
        _write(written[0], root.public_bytes(serialization.Encoding.PEM), secret=False)
        _write(written[1], _key_bytes(root_key), secret=True)
        for peer in peers:
            key = ec.generate_private_key(ec.SECP256R1())
            cert = (
                x509.CertificateBuilder()
                .subject_name(_name(peer))
                .issuer_name(root_name)
                .public_key(key.public_key())
                .serial_number(x509.random_serial_number())
                .not_valid_before(now - datetime.timedelta(minutes=5))
                .not_valid_after(until)
                .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
                .add_extension(x509.SubjectAlternativeName(names), critical=False)
                .add_extension(
                    x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]),
                    critical=False,
                )
                .add_extension(
                    x509.AuthorityKeyIdentifier.from_issuer_public_key(root_key.public_key()), critical=False
                )
                .sign(root_key, hashes.SHA256())
            )
            pem, secret = folder / f"{peer}.pem", folder / f"{peer}.key"
            _write(pem, cert.public_bytes(serialization.Encoding.PEM), secret=False)
            _write(secret, _key_bytes(key), secret=True)
            written += [pem, secret]
    except OSError as e:
        raise RemoteError(f"{folder}: cannot write the certificates: {e.strerror or e}") from None
    return written


__all__ = ["DEFAULT_HOSTS", "DEFAULT_PEERS", "make_certificates"]
