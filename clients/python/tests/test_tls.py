"""``https://`` coordinators: the client reaches one that requires client certificates (mutual
TLS, certificates from ``fmucal certs``) with the CA, certificate and key from its arguments or
the environment, and refuses TLS settings that do not fit the URL."""

from __future__ import annotations

import hashlib
import os
import socket
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from fmucal_client import Client, ConfigurationError, UnavailableError
from fmucal_client.models import example_path

TOKEN = "tls-test-token"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def tls_coordinator(fmucal_bin: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, Path]]:
    """A coordinator under mutual TLS: its URL and the folder of the certificates."""
    folder = tmp_path_factory.mktemp("tls")
    certs = folder / "certs"
    subprocess.run([str(fmucal_bin), "certs", "--out", str(certs)], check=True, capture_output=True, timeout=60)
    port = free_port()
    env = {**os.environ, "FMUCAL_TOKEN": TOKEN}
    coordinator = subprocess.Popen(
        [str(fmucal_bin), "coordinator", "--listen", f"127.0.0.1:{port}", "--data-dir", str(folder / "data"),
         "--tls-cert", str(certs / "coordinator.pem"), "--tls-key", str(certs / "coordinator-key.pem"),
         "--tls-client-ca", str(certs / "ca.pem")],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    try:
        yield f"https://127.0.0.1:{port}", certs
    finally:
        coordinator.terminate()
        coordinator.wait(timeout=30)


def test_mutual_tls_with_files_given_or_from_the_environment(
    tls_coordinator: tuple[str, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    url, certs = tls_coordinator
    furuta = example_path("furuta")
    expected = hashlib.sha256(furuta.read_bytes()).hexdigest()
    with Client(url, token=TOKEN, tls_ca=certs / "ca.pem", tls_cert=certs / "client.pem",
                tls_key=certs / "client-key.pem", connect_timeout=20) as c:
        assert c.upload_model(furuta) == expected
    monkeypatch.setenv("FMUCAL_TLS_CA", str(certs / "ca.pem"))
    monkeypatch.setenv("FMUCAL_TLS_CERT", str(certs / "client.pem"))
    monkeypatch.setenv("FMUCAL_TLS_KEY", str(certs / "client-key.pem"))
    with Client(url, token=TOKEN) as c:
        assert c.upload_model(furuta) == expected


def test_without_a_client_certificate_the_coordinator_is_not_reached(tls_coordinator: tuple[str, Path]) -> None:
    url, certs = tls_coordinator
    with pytest.raises(UnavailableError):
        with Client(url, token=TOKEN, tls_ca=certs / "ca.pem", connect_timeout=2) as c:
            c.upload_model(example_path("furuta"))


def test_tls_settings_must_fit_the_url(tls_coordinator: tuple[str, Path], monkeypatch: pytest.MonkeyPatch) -> None:
    url, certs = tls_coordinator
    monkeypatch.delenv("FMUCAL_TLS_CA", raising=False)
    with pytest.raises(ConfigurationError, match="uses TLS: give the CA"):
        Client(url, token=TOKEN)
    with pytest.raises(ConfigurationError, match="is not https://"):
        Client(url.replace("https://", "http://"), token=TOKEN, tls_ca=certs / "ca.pem")
    with pytest.raises(ConfigurationError, match="give both a client certificate and its key"):
        Client(url, token=TOKEN, tls_ca=certs / "ca.pem", tls_cert=certs / "client.pem")
    with pytest.raises(ConfigurationError, match="is not a coordinator URL"):
        Client("127.0.0.1:50051", token=TOKEN)
