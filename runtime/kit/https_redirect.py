"""The plain-HTTP port beside an HTTPS UI (`tls.redirect_port`): every request is sent on to
the same path on the HTTPS port, except the runtime's certificate authority, which a tablet
fetches here to trust the HTTPS port (and checks by its fingerprint)."""

from __future__ import annotations

from pathlib import Path
from urllib.parse import quote

from starlette.responses import PlainTextResponse, RedirectResponse, Response
from starlette.types import Receive, Scope, Send

from openpendant.runtime.kit.tls import CA_DOWNLOAD
from openpendant.runtime.kit.web_guard import WebPolicy, split_host

CA_TYPE = "application/x-x509-ca-cert"


def ca_response(ca: Path) -> Response:
    return Response(
        ca.read_bytes(),
        media_type=CA_TYPE,
        headers={
            "Content-Disposition": 'attachment; filename="openpendant-ca.crt"',
            "X-Content-Type-Options": "nosniff",
        },
    )


class HttpsRedirect:
    def __init__(self, policy: WebPolicy, https_port: int, ca: Path | None) -> None:
        self.policy = policy
        self.https_port = https_port
        self.ca = ca

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008})
            return
        if scope["type"] != "http":
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
        refusal = self.policy.check_host(headers.get("host"))
        if refusal is not None:
            await PlainTextResponse(refusal.message, refusal.status)(scope, receive, send)
            return
        if scope["path"] == CA_DOWNLOAD and self.ca is not None and scope["method"] == "GET":
            await ca_response(self.ca)(scope, receive, send)
            return
        host, _ = split_host(headers["host"])
        if ":" in host:
            host = f"[{host}]"
        port = "" if self.https_port == 443 else f":{self.https_port}"
        query = scope.get("query_string", b"").decode("latin-1")
        target = f"https://{host}{port}{quote(scope['path'])}" + (f"?{query}" if query else "")
        # 308: the method and body stay what they were (a POST is not turned into a GET).
        await RedirectResponse(target, status_code=308)(scope, receive, send)
