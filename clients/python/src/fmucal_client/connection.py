"""How the client reaches a coordinator, with the CLI's rules and environment variables.

- URL: ``http://HOST:PORT`` is plaintext, ``https://HOST:PORT`` TLS (ports default to 80 and
  443). The TLS server name is the URL's host.
- Token: the ``token`` argument, else the trimmed contents of ``token_file``, else
  ``FMUCAL_TOKEN``; sent as ``authorization: Bearer <token>`` on every call.
- TLS: ``tls_ca`` (else ``FMUCAL_TLS_CA``) is required for an ``https://`` URL and refused for
  an ``http://`` one, as the CLI does; ``tls_cert`` and ``tls_key`` (else ``FMUCAL_TLS_CERT``,
  ``FMUCAL_TLS_KEY``) come together, for a coordinator that requires client certificates.
"""

from __future__ import annotations

import os
from pathlib import Path
from urllib.parse import urlsplit

import grpc

from .errors import ConfigurationError

MAX_MESSAGE_BYTES = 256 << 20
"""The largest message fmucal's peers encode or decode (``fmucal_proto::MAX_MESSAGE_BYTES``)."""

KEEP_ALIVE_MS = 5000
"""How often the client pings its coordinator and how long it waits for the answer
(``fmucal_proto::tls::KEEP_ALIVE``)."""

PathLike = str | os.PathLike[str]


def load_token(token: str | None, token_file: PathLike | None) -> str | None:
    """The client token: ``token``, else ``token_file``'s trimmed text, else ``FMUCAL_TOKEN``.

    Raises:
        ConfigurationError: an unreadable or empty token file, or a token that is not printable ASCII.
    """
    if token is None and token_file is not None:
        try:
            token = Path(token_file).read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError) as e:
            raise ConfigurationError(f"cannot read token file {token_file}: {e}") from e
        if not token:
            raise ConfigurationError(f"token file {token_file} is empty")
    if token is None:
        token = os.environ.get("FMUCAL_TOKEN", "").strip() or None
    if token is not None and not all(" " <= c <= "~" for c in token):
        raise ConfigurationError("the token must be printable ASCII")
    return token


def _flag_or_env(value: PathLike | None, variable: str) -> Path | None:
    if value is not None:
        return Path(value)
    text = os.environ.get(variable, "")
    return Path(text) if text else None


def _read(path: Path, what: str) -> bytes:
    try:
        return path.read_bytes()
    except OSError as e:
        raise ConfigurationError(f"cannot read the {what} {path}: {e}") from e


def target(url: str) -> tuple[str, bool]:
    """The ``host:port`` gRPC dials for ``url``, and whether it is TLS.

    Raises:
        ConfigurationError: a URL that is not ``http://HOST[:PORT]`` or ``https://HOST[:PORT]``.
    """
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise ConfigurationError(f"{url!r} is not a coordinator URL (http://HOST:PORT or https://HOST:PORT)")
    try:
        port = parts.port or (443 if parts.scheme == "https" else 80)
    except ValueError as e:
        raise ConfigurationError(f"{url!r} is not a coordinator URL: {e}") from e
    host = f"[{parts.hostname}]" if ":" in parts.hostname else parts.hostname
    return f"{host}:{port}", parts.scheme == "https"


def credentials(
    url: str, tls_ca: PathLike | None, tls_cert: PathLike | None, tls_key: PathLike | None
) -> grpc.ChannelCredentials | None:
    """The TLS credentials for ``url`` (``None``: plaintext).

    Raises:
        ConfigurationError: TLS settings that do not fit the URL, a certificate without its key,
            or an unreadable file.
    """
    _, tls = target(url)
    ca = _flag_or_env(tls_ca, "FMUCAL_TLS_CA")
    cert = _flag_or_env(tls_cert, "FMUCAL_TLS_CERT")
    key = _flag_or_env(tls_key, "FMUCAL_TLS_KEY")
    if not tls:
        if ca is not None:
            raise ConfigurationError(f"TLS settings were given but {url} is not https://")
        return None
    if ca is None:
        raise ConfigurationError(f"{url} uses TLS: give the CA of its certificate (tls_ca or FMUCAL_TLS_CA)")
    if (cert is None) != (key is None):
        raise ConfigurationError("give both a client certificate and its key (tls_cert and tls_key)")
    return grpc.ssl_channel_credentials(
        root_certificates=_read(ca, "CA certificate"),
        private_key=_read(key, "key") if key is not None else None,
        certificate_chain=_read(cert, "certificate") if cert is not None else None,
    )


def open_channel(url: str, creds: grpc.ChannelCredentials | None) -> grpc.Channel:
    """A channel to ``url`` that carries messages up to :data:`MAX_MESSAGE_BYTES`."""
    address, _ = target(url)
    options = [
        ("grpc.max_send_message_length", MAX_MESSAGE_BYTES),
        ("grpc.max_receive_message_length", MAX_MESSAGE_BYTES),
        # As the CLI: HTTP/2 pings every 5 s, so a peer that vanished is noticed within 10 s.
        ("grpc.keepalive_time_ms", KEEP_ALIVE_MS),
        ("grpc.keepalive_timeout_ms", KEEP_ALIVE_MS),
        ("grpc.keepalive_permit_without_calls", 1),
        ("grpc.http2.max_pings_without_data", 0),
    ]
    if creds is None:
        return grpc.insecure_channel(address, options=options)
    return grpc.secure_channel(address, creds, options=options)
