"""A plan's files handed to a phone or a DJI remote controller on the local network (`serve --lan`).

The page stays on this machine's loopback address. With `--lan` the server also listens on the
network, where it answers one kind of request only: GET `/lan/{token}/{name}` of a file the pilot
shared from the page (its fly block's QR button), by an unguessable token made for that share.
Everything else asked from another machine (the page, the API, a file by its plan id) is refused
with 403, and the Host and Origin rules for the page stay as on loopback.

  POST /api/plans/{pid}/share/{name}  → {"url": ..., "qr_png": base64 PNG of a QR code of the URL}
  GET  /lan/{token}/{name}            the shared file (attachment), from any machine on the network
"""

from __future__ import annotations

import base64
import io
import ipaddress
import secrets
import socket
import threading
from collections import OrderedDict
from dataclasses import dataclass, field

from aerosurvey.errors import InputError
from aerosurvey.web.limits import ASGIApp, Receive, Scope, Send, send_json

#: shares kept: the oldest is forgotten beyond this (each is a token → plan id, file name)
KEEP_SHARES = 64


def is_loopback(address: str | None) -> bool:
    if address is None:
        return False
    if address == "localhost":
        return True
    try:
        return ipaddress.ip_address(address).is_loopback
    except ValueError:
        return False


def local_network_address() -> str:
    """This machine's address on the local network: the one its route to a private address leaves
    from (a UDP socket's connect sends nothing). InputError when there is none."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("10.255.255.255", 1))
            address = str(s.getsockname()[0])
    except OSError as exc:
        raise InputError(f"--lan: this machine has no address on a local network ({exc}); give one with --lan-address") from exc
    if is_loopback(address) or not ipaddress.ip_address(address).is_private:
        raise InputError(f"--lan: the address found, {address}, is not on a local (private) network; give one with --lan-address")
    return address


def qr_png(text: str) -> bytes:
    """A QR code of `text` (error correction M, 4 pixels a module, the standard 4-module quiet zone) as PNG."""
    import segno

    buf = io.BytesIO()
    segno.make(text, error="m").save(buf, kind="png", scale=4, border=4)
    return buf.getvalue()


@dataclass
class Shares:
    """The files shared on the network: token → (plan id, file name), the newest KEEP_SHARES."""

    base_url: str  # http://ADDRESS:PORT
    _by_token: OrderedDict[str, tuple[str, str]] = field(default_factory=OrderedDict)
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def share(self, plan_id: str, name: str) -> dict[str, str]:
        token = secrets.token_urlsafe(16)
        with self._lock:
            self._by_token[token] = (plan_id, name)
            while len(self._by_token) > KEEP_SHARES:
                self._by_token.popitem(last=False)
        from urllib.parse import quote

        url = f"{self.base_url}/lan/{token}/{quote(name, safe='')}"
        return {"url": url, "qr_png": base64.b64encode(qr_png(url)).decode("ascii")}

    def get(self, token: str) -> tuple[str, str] | None:
        with self._lock:
            return self._by_token.get(token)


class LanGate:
    """Requests from another machine (a client address that is not loopback) may only GET or
    HEAD a shared file, `/lan/...`, sent to the LAN address (`lan_host`, "ADDRESS:PORT"); any
    other is refused with 403. Requests from this machine pass on unchanged."""

    def __init__(self, app: ASGIApp, lan_host: str):
        self.app = app
        self.lan_host = lan_host.lower()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        client = scope.get("client")
        if is_loopback(client[0] if client else None):
            await self.app(scope, receive, send)
            return
        host = dict(scope.get("headers") or []).get(b"host", b"").decode("latin-1").lower()
        if scope["method"] in ("GET", "HEAD") and scope["path"].startswith("/lan/") and host == self.lan_host:
            await self.app(scope, receive, send)
            return
        await send_json(send, 403, {"error": "only files shared from the page (its QR codes) are served to the network; "
                                             "open the page on this machine", "key": None})
