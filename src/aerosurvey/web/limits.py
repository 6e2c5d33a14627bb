"""ASGI guards for a server on the user's own machine.

`HostCheck` answers only to the host names it is served on (a web site in the user's
browser cannot reach it through DNS rebinding) and refuses state-changing requests from
other origins, also when it answers any host name (`serve --host` on a network address).
`BodyLimit` stops a request body at the upload limit, whether or not the client announced
its length.
"""

from __future__ import annotations

import json
from collections.abc import Awaitable, Callable, MutableMapping
from typing import Any

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]


class _TooLarge(Exception):
    pass


async def send_json(send: Send, status: int, body: dict[str, Any]) -> None:
    data = json.dumps(body).encode("utf-8")
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(data)).encode())]})
    await send({"type": "http.response.body", "body": data})


class BodyLimit:
    def __init__(self, app: ASGIApp, limit: int):
        self.app = app
        self.limit = limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or [])
        declared = headers.get(b"content-length")
        message = {"error": f"request body larger than the upload limit of {self.limit / 1048576:.0f} MB", "key": None}
        if declared is not None and declared.isdigit() and int(declared) > self.limit:
            await send_json(send, 413, message)
            return
        seen = 0
        started = False

        async def counted_receive() -> Message:
            nonlocal seen
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > self.limit:
                    raise _TooLarge()
            return msg

        async def tracked_send(msg: Message) -> None:
            nonlocal started
            if msg["type"] == "http.response.start":
                started = True
            await send(msg)

        try:
            await self.app(scope, counted_receive, tracked_send)
        except _TooLarge:
            if not started:
                await send_json(send, 413, message)


class HostCheck:
    """`allowed_hosts`: the Host headers answered (None: any, a server on a network address). State-changing
    requests (not GET, HEAD or OPTIONS) from a browser are refused unless they come from the page itself: their
    Origin is one of the allowed hosts or, with any Host answered, the Host they were sent to."""

    def __init__(self, app: ASGIApp, allowed_hosts: list[str] | None):
        self.app = app
        self.allowed = None if allowed_hosts is None else {h.lower() for h in allowed_hosts}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or [])
        host = headers.get(b"host", b"").decode("latin-1").lower()
        if self.allowed is not None and host not in self.allowed:
            await send_json(send, 421, {"error": f"Host {host!r} is not served here; open one of {sorted(self.allowed)}", "key": None})
            return
        origin = headers.get(b"origin")
        if scope["method"] not in ("GET", "HEAD", "OPTIONS") and origin is not None:
            o = origin.decode("latin-1").lower().split("://", 1)[-1]
            if o not in (self.allowed if self.allowed is not None else {host}):
                await send_json(send, 403, {"error": f"requests from origin {origin.decode('latin-1')!r} are refused", "key": None})
                return
        await self.app(scope, receive, send)
