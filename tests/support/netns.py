"""Network namespaces joined by veth pairs, made by a test for itself: a "runtime computer"
and "driver boards" on their own little network (DESIGN.md §8: nothing leaves them).

A thread enters a namespace with setns(2); sockets and child processes it creates meanwhile
belong to that namespace, and stay there after it leaves. Needs root (CAP_SYS_ADMIN) and
iproute2."""

from __future__ import annotations

import contextlib
import ctypes
import os
import shutil
import subprocess
import uuid
from collections.abc import Iterator
from dataclasses import dataclass, field

CLONE_NEWNET = 0x40000000


def available() -> str | None:
    """None when namespaces can be made here, else why not."""
    if shutil.which("ip") is None:
        return "iproute2's ip is not installed"
    if os.geteuid() != 0:
        return "network namespaces need root"
    probe = f"opprobe{uuid.uuid4().hex[:6]}"
    made = subprocess.run(["ip", "netns", "add", probe], capture_output=True, text=True)
    if made.returncode != 0:
        return f"ip netns add failed: {made.stderr.strip()}"
    subprocess.run(["ip", "netns", "del", probe], check=False)
    return None


def ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True)


def _setns(path: str) -> None:
    libc = ctypes.CDLL("libc.so.6", use_errno=True)
    fd = os.open(path, os.O_RDONLY)
    try:
        if libc.setns(fd, CLONE_NEWNET) != 0:
            raise OSError(ctypes.get_errno(), f"setns {path}")
    finally:
        os.close(fd)


@contextlib.contextmanager
def inside(namespace: str) -> Iterator[None]:
    """This thread in `namespace` for the block (then back where it was)."""
    original = os.open("/proc/thread-self/ns/net", os.O_RDONLY)
    try:
        _setns(f"/var/run/netns/{namespace}")
        try:
            yield
        finally:
            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            if libc.setns(original, CLONE_NEWNET) != 0:
                raise OSError(ctypes.get_errno(), "setns back")
    finally:
        os.close(original)


@dataclass
class Link:
    """A veth pair between two namespaces, on a /24 of its own."""

    left: str
    right: str
    left_if: str
    right_if: str
    left_ip: str
    right_ip: str

    def down(self) -> None:
        ip("-n", self.left, "link", "set", self.left_if, "down")

    def up(self) -> None:
        ip("-n", self.left, "link", "set", self.left_if, "up")


@dataclass
class Network:
    """Namespaces with loopback up, joined by veth links. Removed on close."""

    tag: str = field(default_factory=lambda: uuid.uuid4().hex[:5])
    namespaces: list[str] = field(default_factory=list)
    links: list[Link] = field(default_factory=list)

    def namespace(self, role: str) -> str:
        name = f"op{role}{self.tag}"
        ip("netns", "add", name)
        self.namespaces.append(name)
        ip("-n", name, "link", "set", "lo", "up")
        return name

    def link(self, left: str, right: str) -> Link:
        number = len(self.links) + 1
        subnet = f"10.77.{number}"
        left_if, right_if = f"v{self.tag}{number}a", f"v{self.tag}{number}b"
        ip("link", "add", left_if, "type", "veth", "peer", "name", right_if)
        ip("link", "set", left_if, "netns", left)
        ip("link", "set", right_if, "netns", right)
        for ns, interface, address in ((left, left_if, 1), (right, right_if, 2)):
            ip("-n", ns, "addr", "add", f"{subnet}.{address}/24", "dev", interface)
            ip("-n", ns, "link", "set", interface, "up")
            ip("-n", ns, "link", "set", interface, "multicast", "on")
        made = Link(left, right, left_if, right_if, f"{subnet}.1", f"{subnet}.2")
        self.links.append(made)
        return made

    def close(self) -> None:
        for name in self.namespaces:
            subprocess.run(["ip", "netns", "del", name], check=False, capture_output=True)
        self.namespaces.clear()
