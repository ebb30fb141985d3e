"""The swarm's own certificate authority: a CA and one certificate per node, made with
``cryptography`` so that nothing depends on an ``openssl`` binary being installed.

Every certificate's common name is the node's name: the router's access control tells
nodes apart by it (``cert_common_names``), so it is the node's identity.
"""

from __future__ import annotations

import datetime
import ipaddress
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from wiswarm_zenoh.security.configs import CA_CERT, CA_KEY
from wiswarm_zenoh.security.credentials import write_private

LOCAL_NAMES = ("localhost", "127.0.0.1")
SKEW = datetime.timedelta(minutes=5)  # certificates start a little early: clocks differ


@dataclass(frozen=True)
class Authority:
    """The CA that signs every node of one swarm."""

    cert: x509.Certificate
    key: ec.EllipticCurvePrivateKey


def _name(common_name: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def _general_name(host: str) -> x509.GeneralName:
    """An IP address SAN for an address, a DNS name SAN for anything else."""
    try:
        return x509.IPAddress(ipaddress.ip_address(host))
    except ValueError:
        return x509.DNSName(host)


def _window(days: int) -> tuple[datetime.datetime, datetime.datetime]:
    now = datetime.datetime.now(datetime.UTC)
    return now - SKEW, now + datetime.timedelta(days=days)


def new_authority(swarm: str, days: int) -> Authority:
    """A fresh self-signed CA for ``swarm``; it may sign leaf certificates only."""
    key = ec.generate_private_key(ec.SECP256R1())
    start, end = _window(days)
    name = _name(f"wiswarm {swarm} CA")
    cert = (
        x509.CertificateBuilder().subject_name(name).issuer_name(name)
        .public_key(key.public_key()).serial_number(x509.random_serial_number())
        .not_valid_before(start).not_valid_after(end)
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(x509.KeyUsage(
            digital_signature=True, key_cert_sign=True, crl_sign=True, content_commitment=False,
            key_encipherment=False, data_encipherment=False, key_agreement=False,
            encipher_only=False, decipher_only=False), critical=True)
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()),
                       critical=False)
        .sign(key, hashes.SHA256())
    )
    return Authority(cert, key)


def issue(authority: Authority, common_name: str, days: int,
          hosts: Sequence[str] = ()) -> tuple[x509.Certificate, ec.EllipticCurvePrivateKey]:
    """A certificate for one node, good as TLS server and client alike (a router listens,
    a node connects); SANs: this machine and ``hosts``, so the router's name checks."""
    key = ec.generate_private_key(ec.SECP256R1())
    start, end = _window(days)
    names = [_general_name(h) for h in dict.fromkeys((*LOCAL_NAMES, *hosts))]
    ca_key_id = authority.cert.extensions.get_extension_for_class(x509.SubjectKeyIdentifier)
    cert = (
        x509.CertificateBuilder().subject_name(_name(common_name))
        .issuer_name(authority.cert.subject).public_key(key.public_key())
        .serial_number(x509.random_serial_number()).not_valid_before(start)
        .not_valid_after(min(end, authority.cert.not_valid_after_utc))
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(x509.KeyUsage(
            digital_signature=True, key_cert_sign=False, crl_sign=False,
            content_commitment=False, key_encipherment=False, data_encipherment=False,
            key_agreement=False, encipher_only=False, decipher_only=False), critical=True)
        .add_extension(x509.ExtendedKeyUsage(
            [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
        .add_extension(x509.SubjectAlternativeName(names), critical=False)
        .add_extension(x509.AuthorityKeyIdentifier.from_issuer_subject_key_identifier(
            ca_key_id.value), critical=False)
        .sign(authority.key, hashes.SHA256())
    )
    return cert, key


def write_pair(directory: Path, stem: str, cert: x509.Certificate,
               key: ec.EllipticCurvePrivateKey) -> tuple[Path, Path]:
    """``<stem>.pem`` and ``<stem>-key.pem``; the key is readable by its owner only."""
    cert_path, key_path = directory / f"{stem}.pem", directory / f"{stem}-key.pem"
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    write_private(key_path, key.private_bytes(serialization.Encoding.PEM,
                                              serialization.PrivateFormat.PKCS8,
                                              serialization.NoEncryption()))
    return cert_path.resolve(), key_path.resolve()


def load_authority(directory: Path) -> Authority:
    """The CA written by ``init`` (ValueError/OSError if it is missing or not a CA key)."""
    cert = x509.load_pem_x509_certificate((directory / CA_CERT).read_bytes())
    key = serialization.load_pem_private_key((directory / CA_KEY).read_bytes(), None)
    if not isinstance(key, ec.EllipticCurvePrivateKey):
        raise ValueError(f"{directory / CA_KEY} is not an EC private key")
    return Authority(cert, key)


def common_name(cert: x509.Certificate) -> str:
    """The certificate's subject common name ("" if it has none)."""
    names = cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)
    return str(names[0].value) if names else ""
