"""A Robot Raconteur node of this process's own, set up for OpenPendant.

Not RR's default node and never `RobotRaconteur.Client` (importing it starts a node that
listens and asks for services on every interface). Only the TCP transport: no local
transport (it would write node ids and sockets under RR's system folders), and no RR
discovery unless asked (it sends on every interface of the machine). The arguments RR reads
from a command line are given, never taken from this process's own."""

from __future__ import annotations

import threading
from typing import Any

import RobotRaconteur as RR
import RobotRaconteurCompanion as RRC

FLAGS = {
    n.removeprefix("RobotRaconteurNodeSetupFlags_"): getattr(RR, n)
    for n in dir(RR)
    if n.startswith("RobotRaconteurNodeSetupFlags_")
}
# A link that stops answering is noticed within a second, not RR's default 15 s.
HEARTBEAT_MS = 200
RECEIVE_TIMEOUT_MS = 1000
REQUEST_TIMEOUT_MS = 3000


class Node:
    """A node and the setup that owns it; `close()` shuts it down for good."""

    def __init__(
        self, name: str = "", *, serve_port: int | None = None, localhost_only: bool = False
    ) -> None:
        self.node = RR.RobotRaconteurNode()
        self.node.Init()
        flags = FLAGS["CLIENT_DEFAULT"] if serve_port is None else FLAGS["SERVER_DEFAULT"]
        flags &= ~(
            FLAGS["ENABLE_LOCAL_TRANSPORT"]
            | FLAGS["LOCAL_TRANSPORT_START_CLIENT"]
            | FLAGS["LOCAL_TRANSPORT_START_SERVER"]
            | FLAGS["ENABLE_NODE_ANNOUNCE"]
            | FLAGS["ENABLE_NODE_DISCOVERY_LISTENING"]
            | FLAGS["TCP_TRANSPORT_IPV6_DISCOVERY"]
            | FLAGS["TCP_TRANSPORT_IPV4_DISCOVERY"]
        )
        if localhost_only:
            flags |= FLAGS["TCP_TRANSPORT_LISTEN_LOCALHOST"]
        self.setup = RR.RobotRaconteurNodeSetup(
            name, serve_port or 0, flags, 0, node=self.node, argv=["openpendant"]
        )
        tcp = self.setup.tcp_transport
        tcp._SetDefaultHeartbeatPeriod(HEARTBEAT_MS)
        tcp._SetDefaultReceiveTimeout(RECEIVE_TIMEOUT_MS)
        self.node._SetRequestTimeout(REQUEST_TIMEOUT_MS)
        RRC.RegisterStdRobDefServiceTypes(self.node)
        self._closed = threading.Event()

    def connect(self, url: str, user: str | None = None, password: str | None = None) -> Any:
        if user is None:
            return self.node.ConnectService(url)
        credentials = {"password": RR.VarValue(password or "", "string")}
        return self.node.ConnectService(url, user, credentials)

    def constants(self, namespace: str, client: Any) -> dict[str, Any]:
        return dict(self.node.GetConstants(namespace, client))

    def structure(self, name: str, client: Any) -> Any:
        return self.node.GetStructureType(name, client)

    def close(self) -> None:
        if not self._closed.is_set():
            self._closed.set()
            self.setup.close()
