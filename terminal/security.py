"""The terminal's access rules: the token, where it may come from, and which addresses need one.

- On 127.0.0.1 (``localhost``, ``::1``) no token is needed unless a token file is given; on any other
  address one is: read from ``~token_file`` or generated at start (printed in the URL, as Jupyter does).
- A client shows the token in any of: the ``Authorization: Bearer TOKEN`` (or ``token TOKEN``) header, the
  ``token`` query parameter, the cookie the page sets, or, on the WebSocket, rosbridge's ``auth`` op with the
  token as its ``mac``. Every comparison is constant-time (:func:`hmac.compare_digest`).
- Without a token, requests must name this machine as their Host (a web page elsewhere cannot reach the
  terminal through DNS rebinding), and browsers' WebSockets must come from the terminal's own page (Origin),
  unless the origin is listed in ``~allowed_origins``.
"""
from __future__ import annotations

import hmac
import secrets
from pathlib import Path
from urllib.parse import urlsplit

LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")
COOKIE_PREFIX = "terminal_token_"


class TokenError(ValueError):
    """A token file that cannot be used; the message names the file."""


def needs_token(host: str, token_file: str | None) -> bool:
    """A token is needed on every address but loopback, and wherever a token file is given."""
    return bool(token_file) or host not in LOOPBACK_HOSTS


def generate_token() -> str:
    """A new random token for a terminal listening beyond loopback (48 hex digits)."""
    return secrets.token_hex(24)


def read_token_file(path: str) -> str:
    """The first line of `path`, stripped; an empty or unreadable file is an error naming it."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as error:
        raise TokenError(f"token file {path}: cannot read it ({error.strerror or error})") from None
    except UnicodeDecodeError:
        raise TokenError(f"token file {path}: not UTF-8 text") from None
    lines = text.strip().splitlines()
    token = lines[0].strip() if lines else ""
    if len(token) < 8:
        raise TokenError(f"token file {path}: the token (first line) must be at least 8 characters")
    return token


def token_matches(given: str | None, token: str) -> bool:
    """Constant-time comparison (the time taken does not reveal how much of a guess was right)."""
    if not given:
        return False
    return hmac.compare_digest(given.encode("utf-8"), token.encode("utf-8"))


def token_from_header(value: str | None) -> str | None:
    """The token of an ``Authorization: Bearer TOKEN`` or ``Authorization: token TOKEN`` header."""
    if not value:
        return None
    scheme, _, credentials = value.strip().partition(" ")
    if scheme.lower() in ("bearer", "token") and credentials.strip():
        return credentials.strip()
    return None


def cookie_name(port: int) -> str:
    """Cookies are not per port, so the name carries it: two terminals on one host keep their own."""
    return f"{COOKIE_PREFIX}{port}"


def host_is_local(host_header: str | None, port: int) -> bool:
    """Whether a request's Host names this machine by a loopback name (the DNS-rebinding check)."""
    if not host_header:
        return False
    name = urlsplit(f"//{host_header}").hostname or ""
    return name in LOOPBACK_HOSTS


def origin_allowed(origin: str | None, host_header: str | None, allowed: tuple[str, ...]) -> bool:
    """A WebSocket from a browser must come from this terminal's own page or an allowed origin.

    Clients that are not browsers (roslibpy, rostopic-like tools) send no Origin and are let through.
    """
    if origin is None:
        return True
    if origin in allowed or "*" in allowed:
        return True
    parts = urlsplit(origin)
    return bool(host_header) and parts.netloc == host_header and parts.scheme in ("http", "https")
