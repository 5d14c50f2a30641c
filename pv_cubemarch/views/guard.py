"""Who may use a live view: only its own page, holding the server's token.

A live view's server renders, turns knobs and runs CPU reference renders for whoever
connects. So each server gets a random token (never wslink's published default), a
websocket is accepted only from the page's own origin (a web page the user visits cannot
drive it), every client message is bounded before memory is set aside for it, and a
server that listens beyond this machine says so loudly.
"""

from __future__ import annotations

import hmac
import ipaddress
import os
import secrets
import struct
import sys
import warnings
from urllib.parse import parse_qsl, urlencode, urlsplit, urlunsplit

#: The most one client message (all its wslink chunks together) may claim, in bytes;
#: also the most all of a client's unfinished messages may hold at once.
MAX_MESSAGE_BYTES = 16 << 20
#: Extra origins allowed to open the websocket (comma separated), for a proxy in front.
ORIGINS_ENV = "PV_CUBEMARCH_ALLOWED_ORIGINS"
#: The query parameter the trame page reads its secret from.
TOKEN_PARAMETER = "secret"
_LOOPBACK_NAMES = {"localhost", "localhost.localdomain", "ip6-localhost", "ip6-loopback"}


class LiveViewWarning(UserWarning):
    """A live view is reachable from other machines."""


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or an address) is this machine only."""
    host = (host or "").strip("[]").lower()
    if host in _LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def warn_if_exposed(host: str) -> None:
    """Warn, on stderr too, when a server listens on a non-loopback address."""
    if is_loopback(host):
        return
    message = (f"the live view listens on {host!r}, reachable from other machines: anyone "
               "who has its URL (with its secret) can read the scene, turn its knobs and "
               "run CPU reference renders; use --host 127.0.0.1 (the default) and an SSH "
               "tunnel unless the network is trusted")
    print(f"WARNING: {message}", file=sys.stderr, flush=True)
    warnings.warn(message, LiveViewWarning, stacklevel=3)


def with_token(url: str, token: str) -> str:
    """``url`` with the server's token as the page's ``secret`` query parameter."""
    parts = urlsplit(url)
    query = [(k, v) for k, v in parse_qsl(parts.query) if k != TOKEN_PARAMETER]
    query.append((TOKEN_PARAMETER, token))
    return urlunsplit(parts._replace(query=urlencode(query)))


def guard(server) -> str:
    """Let only the page of ``server`` (a trame server, not started yet) in; return its token.

    The token replaces wslink's secret check (compared in constant time, whatever
    ``--authKey`` says); the websocket upgrade must come from the page's own origin; and
    each connection's messages are bounded by :data:`MAX_MESSAGE_BYTES`.
    """
    from wslink.websocket import LinkProtocol

    token = secrets.token_urlsafe(32)

    class TokenCheck(LinkProtocol):
        """Accept a client whose hello carries this server's token."""

        async def validateToken(self, candidate, client_id):  # noqa: N802 - wslink's name
            return isinstance(candidate, str) and hmac.compare_digest(
                candidate.encode(), token.encode())

    server.add_protocol_to_configure(
        lambda protocol: protocol.registerLinkProtocol(TokenCheck()))

    @server.controller.add("on_server_bind")
    def _bind(web_server):
        web_server.app.middlewares.append(_same_origin_only())
        for handler in getattr(web_server, "_ws_handlers", ()):
            _bound_messages(handler)

    return token


def _origin_key(url: str) -> tuple[str, str, int] | None:
    """(scheme, host, port) of an origin or URL, or None when it is not http(s)."""
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https"):
        return None
    try:
        port = parts.port
    except ValueError:
        return None
    default = 443 if parts.scheme == "https" else 80
    return parts.scheme, (parts.hostname or "").lower(), port or default


def _same_origin_only():
    """An aiohttp middleware refusing (403) a websocket upgrade from another origin."""
    from aiohttp import web

    extra = {_origin_key(o.strip()) for o in os.environ.get(ORIGINS_ENV, "").split(",")
             if o.strip()}

    @web.middleware
    async def same_origin(request, handler):
        if request.headers.get("Upgrade", "").lower() == "websocket":
            origin = request.headers.get("Origin", "")
            key = _origin_key(origin)
            page = _origin_key(f"{key[0] if key else 'http'}://{request.headers.get('Host', '')}")
            if key is None or (key != page and key not in extra):
                raise web.HTTPForbidden(
                    text=f"websocket from origin {origin!r} refused: only the live view's "
                         f"own page may connect (set {ORIGINS_ENV} for a proxy in front)")
        return await handler(request)

    return same_origin


def _bound_messages(handler) -> None:
    """Give each new connection of a wslink handler a bounded un-chunker."""
    from wslink.chunking import UnChunker

    class BoundedUnChunker(UnChunker):
        """wslink's un-chunker, bounded per message and over unfinished messages.

        wslink lets an authenticated client claim up to 4 GB per message, allocated as
        soon as a 12-byte chunk header arrives.
        """

        def set_max_message_size(self, size):
            super().set_max_message_size(min(int(size), MAX_MESSAGE_BYTES))

        def process_chunk(self, chunk: bytes):
            if len(chunk) >= 12:
                ident, _offset, total = struct.unpack("<III", chunk[:12])
                if ident not in self.pending_messages:
                    held = sum(len(m["content"]) for m in self.pending_messages.values())
                    if held + total > MAX_MESSAGE_BYTES:
                        self.release_pending_messages()
                        raise ValueError(f"a client message of {total} bytes (with {held} "
                                         f"pending) is over the live view's bound of "
                                         f"{MAX_MESSAGE_BYTES} bytes: refused")
            return super().process_chunk(chunk)

    connect = handler.onConnect

    async def on_connect(request, client_id):
        await connect(request, client_id)
        handler.unchunkers[client_id] = BoundedUnChunker()

    handler.onConnect = on_connect
