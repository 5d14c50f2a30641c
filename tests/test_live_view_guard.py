"""The live view lets in only its own page: a fresh token, the page's origin, bounded messages.

A websocket client (aiohttp's, the library wslink serves with) talks to a live view's
server the way trame's page does: a chunked msgpack ``wslink.hello`` carrying the secret.
Each refusal is checked with the page still working after it (its next connection with
the token says hello back, its HTTP page is served).
"""

from __future__ import annotations

import asyncio
import re
import struct
import urllib.request
import warnings
from urllib.parse import parse_qs, urlsplit

import aiohttp
import msgpack
import numpy as np
import pytest
import pyvista

import pv_cubemarch as cm
from pv_cubemarch.views import guard, live

SIZE = (160, 120)


@pytest.fixture
def view():
    pl = pyvista.Plotter(notebook=True, window_size=SIZE)
    x, y, z = np.mgrid[-1:1:12j, -1:1:12j, -1:1:12j]
    cm.add_volume(pl, np.exp(-4 * (x * x + y * y + z * z)), technique="direct")
    shown = cm.live_view(pl)
    yield shown
    live._VIEWS.pop(pl, None)
    shown.close()
    pl.close()


def _run(coroutine):
    """Run a client coroutine on the loop the view's server runs on."""
    return asyncio.get_event_loop().run_until_complete(coroutine)


def _token(view) -> str:
    return parse_qs(urlsplit(view.url).query)["secret"][0]


def _endpoints(view) -> tuple[str, str]:
    """The view's websocket URL and its page's origin (as the browser sends it)."""
    parts = urlsplit(view.url)
    return f"ws://{parts.netloc}/ws", f"http://{parts.netloc}"


def _chunk(payload: bytes, ident: int = 1, total: int | None = None) -> bytes:
    """One wslink chunk: id, offset, the whole message's size, then the bytes."""
    return struct.pack("<III", ident, 0, len(payload) if total is None else total) + payload


async def _hello(ws, secret) -> dict:
    message = {"wslink": "1.0", "id": "system:c0:0", "method": "wslink.hello",
               "args": [{"secret": secret}], "kwargs": {}}
    await ws.send_bytes(_chunk(msgpack.packb(message)))
    while True:
        reply = await asyncio.wait_for(ws.receive(), 20)
        if reply.type != aiohttp.WSMsgType.BINARY:
            return {"closed": reply.type.name}
        answer = msgpack.unpackb(reply.data[12:])
        if answer.get("id") == "system:c0:0":
            return answer


async def _connect_and_hello(url, origin, secret):
    async with aiohttp.ClientSession() as http, http.ws_connect(
            url, headers={} if origin is None else {"Origin": origin}) as ws:
        return await _hello(ws, secret)


def _rss_bytes() -> int:
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) * 1024 for line in status
                    if line.startswith("VmRSS:"))


def _page_still_works(view):
    url, origin = _endpoints(view)
    answer = _run(_connect_and_hello(url, origin, _token(view)))
    assert "result" in answer and "clientID" in answer["result"], answer
    async def fetch():
        loop = asyncio.get_running_loop()
        return await loop.run_in_executor(None, lambda: urllib.request.urlopen(
            view.url, timeout=10).read())
    assert b"trame" in _run(fetch())


def test_each_view_has_a_fresh_token_in_its_url(view):
    # catches: the page URL without the secret (the page could not connect), or a fixed one
    token = _token(view)
    assert len(token) >= 32 and token != "wslink-secret"
    assert re.fullmatch(r"[A-Za-z0-9_-]+", token)
    assert guard.guard(_UnstartedServer()) != token
    _page_still_works(view)


class _UnstartedServer:
    """What guard() touches of a trame server."""

    class controller:  # noqa: N801 - trame's attribute name
        @staticmethod
        def add(_name):
            return lambda function: function

    def add_protocol_to_configure(self, _configure):
        pass


def test_the_default_secret_and_a_wrong_token_are_refused(view):
    # catches: wslink's published default ("wslink-secret") still accepted (guard() not
    # called, or its token check not registered)
    url, origin = _endpoints(view)
    for secret in ("wslink-secret", _token(view)[:-1] + "x", "", 12345):
        answer = _run(_connect_and_hello(url, origin, secret))
        assert "result" not in answer, (secret, answer)
        assert "Authentication failed" in str(answer.get("error", answer)), answer
    _page_still_works(view)


@pytest.mark.parametrize("origin", ["http://evil.example", "http://127.0.0.1:1", None,
                                    "null", "file://"])
def test_a_websocket_from_another_origin_is_refused(view, origin):
    # catches: the Origin middleware missing (a web page the user visits could connect)
    url, _ = _endpoints(view)
    with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
        _run(_connect_and_hello(url, origin, _token(view)))
    assert refused.value.status == 403
    _page_still_works(view)


def test_a_message_claiming_a_gibibyte_is_refused_before_allocation(view):
    # catches: wslink's un-chunker left unbounded after the hello (it would set aside the
    # 1 GiB a 13-byte message claims until the socket closes)
    url, origin = _endpoints(view)

    async def attack():
        async with aiohttp.ClientSession() as http, http.ws_connect(
                url, headers={"Origin": origin}) as ws:
            assert "result" in await _hello(ws, _token(view))
            before = _rss_bytes()
            await ws.send_bytes(_chunk(b"x", ident=7, total=1 << 30))   # 13 bytes
            for ident in range(8, 40):          # nor many messages claiming 15 MiB each
                await ws.send_bytes(_chunk(b"x", ident=ident, total=15 << 20))
            await asyncio.sleep(0.5)
            return _rss_bytes() - before

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        grown = _run(attack())
    assert grown < 100 << 20, f"the server grew by {grown / 2**20:.0f} MiB"
    _page_still_works(view)


@pytest.mark.parametrize("host", ["0.0.0.0", "::", "192.168.1.20", "example.org"])
def test_a_non_loopback_host_warns_loudly(host, capsys):
    # catches: binding every interface without a word
    with pytest.warns(guard.LiveViewWarning, match="reachable from other machines"):
        guard.warn_if_exposed(host)
    assert "WARNING" in capsys.readouterr().err


@pytest.mark.parametrize("host", ["127.0.0.1", "localhost", "::1", "[::1]", "127.0.0.5"])
def test_a_loopback_host_is_quiet(host, capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        guard.warn_if_exposed(host)
    assert capsys.readouterr().err == ""


def test_with_token_replaces_any_secret_already_in_the_url():
    url = guard.with_token("http://h:1/index.html?ui=main&secret=old&reconnect=auto", "t0k")
    assert parse_qs(urlsplit(url).query) == {"ui": ["main"], "reconnect": ["auto"],
                                             "secret": ["t0k"]}
