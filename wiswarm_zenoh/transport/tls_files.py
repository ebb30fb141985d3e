"""The TLS files a Zenoh config names, checked before a session opens (below the
transport, which checks them at every session it opens; ``security.checks`` builds on
them for the secured sites' own checks).

Zenoh refuses a bad certificate with a TLS error far from its cause (or, on a router, in
the log of the other side); these checks name the file and what is wrong with it, as
one ``UsageError`` line.
"""

from __future__ import annotations

import datetime
import json
from pathlib import Path
from typing import TYPE_CHECKING

import zenoh

from wiswarm_zenoh.usage import UsageError

if TYPE_CHECKING:  # cryptography is loaded when a certificate is read, not by every node
    from cryptography import x509

TLS = "transport/link/tls"
CA = "root_ca_certificate"
PAIRS = (("listen_certificate", "listen_private_key"),
         ("connect_certificate", "connect_private_key"))


def _read(path: str, what: str) -> bytes:
    try:
        return Path(path).read_bytes()
    except OSError as exc:
        raise UsageError(f"{what} {path}: cannot read it ({exc.strerror})") from None


def _certificate(path: str, what: str) -> x509.Certificate:
    """A PEM certificate valid now."""
    from cryptography import x509

    try:
        cert = x509.load_pem_x509_certificate(_read(path, what))
    except ValueError:
        raise UsageError(f"{what} {path}: not a PEM certificate") from None
    now = datetime.datetime.now(datetime.UTC)
    if now < cert.not_valid_before_utc:
        raise UsageError(f"{what} {path}: not valid before "
                         f"{cert.not_valid_before_utc:%Y-%m-%d %H:%M} UTC")
    if now > cert.not_valid_after_utc:
        raise UsageError(f"{what} {path}: expired on "
                         f"{cert.not_valid_after_utc:%Y-%m-%d %H:%M} UTC")
    return cert


def _check_key(path: str, cert: x509.Certificate, cert_path: str) -> None:
    from cryptography.hazmat.primitives import serialization

    try:
        key = serialization.load_pem_private_key(_read(path, "private key"), None)
    except (ValueError, TypeError):
        raise UsageError(f"private key {path}: not an unencrypted PEM private key") from None
    der = serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo
    if key.public_key().public_bytes(*der) != cert.public_key().public_bytes(*der):
        raise UsageError(f"private key {path}: does not match certificate {cert_path}")


def _check_signed(cert: x509.Certificate, path: str, ca: x509.Certificate,
                  ca_path: str) -> None:
    from cryptography.exceptions import InvalidSignature

    try:
        cert.verify_directly_issued_by(ca)
    except (ValueError, TypeError, InvalidSignature):
        raise UsageError(f"certificate {path}: not signed by the CA {ca_path}") from None


def tls_files(config: zenoh.Config) -> dict[str, str]:
    """The TLS files ``config`` names, by their config key."""
    section = json.loads(config.get_json(TLS)) or {}
    return {key: value for key, value in section.items() if key in
            (CA, *[name for pair in PAIRS for name in pair]) and isinstance(value, str)}


def check_tls(config: zenoh.Config) -> dict[str, x509.Certificate]:
    """Check every TLS file ``config`` names: readable, valid now, the certificates
    signed by its CA and each key matching its certificate. Returns the certificates."""
    files = tls_files(config)
    certs: dict[str, x509.Certificate] = {}
    if CA in files:
        certs[CA] = _certificate(files[CA], "CA certificate")
    for cert_key, key_key in PAIRS:
        if cert_key not in files:
            continue
        path = files[cert_key]
        certs[cert_key] = cert = _certificate(path, "certificate")
        if CA in files:
            _check_signed(cert, path, certs[CA], files[CA])
        if key_key in files:
            _check_key(files[key_key], cert, path)
    return certs
