"""The edge-cloud experiment closed (``--secure``): each session is its node's own, over
TLS, and a short run on real namespaces delivers every pair through the hierarchy."""

from __future__ import annotations

import csv
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from cryptography import x509

from wiswarm_zenoh.cli import main as cli
from wiswarm_zenoh.experiments.edge_cloud_secure import Specs
from wiswarm_zenoh.experiments.edge_cloud_topology import Site


def _net(tmp_path: Path) -> tuple[Any, Site]:
    """Two sites as the topology names them, no namespaces built."""
    sites = [Site(f"s{k}", k, SimpleNamespace(  # type: ignore[arg-type]
        leader_ns=f"wsw-l{k}", follower_ns=f"wsw-f{k}", leader_addr=f"10.201.{k}.1"))
        for k in (1, 2)]
    return SimpleNamespace(sites=sites), sites[0]


def test_closed_sessions_speak_tls_each_with_its_nodes_own_config(tmp_path: Path) -> None:
    net, site = _net(tmp_path)
    pki = tmp_path / "pki"
    closed, open_ = Specs(net, ["uav0"], pki), Specs(net, ["uav0"])
    router = closed.site_router(site)
    assert router.config_file == str(pki / "s1" / "router.json5")
    assert router.listen == ("tls/10.201.1.1:7447", "tls/127.0.0.1:7447")
    assert router.connect == ("tls/127.0.0.1:7461",)  # the relay toward the cloud
    assert open_.site_router(site) == site.router()
    assert closed.followers(site).connect == ("tls/10.201.1.1:7447",)
    assert closed.follower_config(site, "uav0") == str(pki / "s1" / "uav0.json5")
    assert open_.follower_config(site, "uav0") is None
    assert closed.leader(None).config_file == str(pki / "leader.json5")
    for spec in (router, closed.cloud_router(), closed.leader(site), closed.leader(None)):
        spec.config()  # Zenoh takes it, certificates checked
    # Followers reach their site's router at its channel address: it is in the certificate.
    cert = x509.load_pem_x509_certificate((pki / "s1" / "router.pem").read_bytes())
    sans = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert "10.201.1.1" in {str(a) for a in sans.get_values_for_type(x509.IPAddress)}


@pytest.mark.testbed
def test_a_short_closed_run_delivers_every_pair_through_the_hierarchy(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "ec"
    code = cli.main(["experiment", "edge-cloud", "--secure", "--sites", "2", "--followers",
                     "1", "--duration", "1", "--warmup", "0.5", "--in-flight", "1",
                     "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0, printed
    assert "Closed (`--secure`)" in printed and "every process ran to the end" in printed
    with (out / "summary.csv").open(newline="") as src:
        rows = list(csv.DictReader(src))
    assert [row["setup"] for row in rows] == ["hierarchy x1", "edge alone"]
    with (out / "records" / "h1-cloud.csv").open(newline="") as src:
        assert {row["follower"] for row in csv.DictReader(src)} == {"s1.uav0", "s2.uav0"}
