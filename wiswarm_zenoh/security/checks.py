"""The TLS files a Zenoh config names, checked before a session opens.

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


def check_identity(config_file: str | None, name: str) -> None:
    """A node started as ``name`` with ``config_file`` must hold ``name``'s certificate:
    the router's rules know it by its certificate's common name (``<site>/<name>`` in a
    site), not by ``--id``."""
    if config_file is None:
        return
    if not Path(config_file).is_file():
        raise UsageError(f"config file {config_file}: no such file (no config for {name!r})")
    try:
        config = zenoh.Config.from_file(config_file)
    except zenoh.ZError:
        return  # the session's own config checks report it, with Zenoh's words
    cert = check_tls(config).get("connect_certificate")
    from wiswarm_zenoh.security.pki import common_name

    if cert is not None and common_name(cert).rpartition("/")[2] != name:
        path = tls_files(config)["connect_certificate"]
        raise UsageError(f"certificate {path} (in {config_file}) is {common_name(cert)}'s, "
                         f"not {name}'s: use {name}'s config, or "
                         f"`wiswarm security add-follower` to make one")


def _written_for(config_file: str | None) -> dict[str, object] | None:
    """What ``wiswarm security`` wrote ``config_file`` for (None: not one of ours)."""
    if config_file is None or not Path(config_file).is_file():
        return None
    try:
        metadata = json.loads(zenoh.Config.from_file(config_file).get_json("metadata"))
    except (zenoh.ZError, ValueError):
        return None  # the session's own config checks report it, with Zenoh's words
    ours = metadata.get("wiswarm") if isinstance(metadata, dict) else None
    return ours if isinstance(ours, dict) else None


def check_swarm(config_file: str | None, swarm: str) -> None:
    """A node started for ``swarm`` with a config that ``wiswarm security`` wrote for
    another swarm would run silently dead (the router's rules cover that swarm's keys
    only): said in one line instead."""
    written_for = (_written_for(config_file) or {}).get("swarm")
    if isinstance(written_for, str) and written_for != swarm:
        raise UsageError(f"{config_file} was written for swarm {written_for!r}, whose rules "
                         f"cover its keys only: pass --swarm {written_for} (or make this "
                         f"swarm's configs with wiswarm security init --swarm {swarm})")


def check_upstream(config_file: str | None, upstream: str | None, site: str) -> None:
    """Likewise upstream: an edge leader's config lets it answer the cloud's swarm for
    its own site's followers only, and another leader's for none."""
    ours = _written_for(config_file)
    if ours is None:
        return
    written, swarm = ours.get("upstream"), ours.get("swarm")
    if written is None and upstream is not None:
        raise UsageError(f"{config_file} was written for a leader with no swarm upstream, "
                         f"whose rules let it serve none: leave out --upstream")
    if written is not None and (upstream, site) != (written, swarm):
        raise UsageError(f"{config_file} was written for the edge leader of site {swarm!r} under "
                         f"{written!r}, whose rules let it serve {written!r} as {swarm!r} "
                         f"only: pass --upstream {written} (and no other --site)")
