"""The kernel's own walls around a worker, each taken where the system grants it: namespaces,
a read-only view of the files, no new privileges and a seccomp filter. Every function says
whether it was granted; none raises, so a host without one still runs programs, and the run
reports what it had (`isolation`)."""

from __future__ import annotations

import ctypes
import errno
import logging
from typing import Any

log = logging.getLogger(__name__)

try:  # ctypes bindings of libseccomp (libseccomp2, in every Debian with apt or systemd)
    import pyseccomp
except (ImportError, OSError):  # no libseccomp on this host
    pyseccomp = None

CLONE_NEWNS = 0x00020000
CLONE_NEWNET = 0x40000000
PR_SET_NO_NEW_PRIVS = 38
MS_RDONLY = 1
MS_NOSUID = 2
MS_NODEV = 4
MS_NOEXEC = 8
MS_REMOUNT = 32
MS_NOATIME = 1024
MS_NODIRATIME = 2048
MS_BIND = 4096
MS_REC = 16384
MS_PRIVATE = 1 << 18
MS_RELATIME = 1 << 21
MS_STRICTATIME = 1 << 24
# A mount's options that a bind remount must repeat (the kernel refuses to drop locked ones).
KEPT_OPTIONS = {
    "nosuid": MS_NOSUID,
    "nodev": MS_NODEV,
    "noexec": MS_NOEXEC,
    "noatime": MS_NOATIME,
    "nodiratime": MS_NODIRATIME,
    "relatime": MS_RELATIME,
    "strictatime": MS_STRICTATIME,
}

# What a program's worker does once it runs: read and write its pipes, wait, sleep, keep
# time, manage memory, take signals, end. Measured by tracing every worker of the program
# tests (futex, write, clock_nanosleep, read, exit_group, mmap, munmap, brk, mprotect,
# rt_sigreturn), with the calls the interpreter makes on paths those runs did not take.
# Everything else (open, socket, ptrace, mount, unshare, keyctl, kill, ioctl, …) is refused
# with EPERM, never run.
ALLOWED = (
    "read",
    "readv",
    "write",
    "writev",
    "futex",
    "clock_nanosleep",
    "nanosleep",
    "clock_gettime",
    "clock_getres",
    "gettimeofday",
    "sched_yield",
    "mmap",
    "munmap",
    "mremap",
    "mprotect",
    "madvise",
    "brk",
    "rt_sigreturn",
    "rt_sigaction",
    "rt_sigprocmask",
    "sigaltstack",
    "restart_syscall",
    "getpid",
    "gettid",
    "getrusage",
    "getrandom",
    "lseek",
    "fstat",
    "close",
    "exit",
    "exit_group",
)

_libc = ctypes.CDLL(None, use_errno=True)


def _failed(what: str) -> bool:
    log.debug("%s not granted: %s", what, errno.errorcode.get(ctypes.get_errno(), "?"))
    return False


def unshare(flags: int) -> bool:
    """A new namespace for this thread (call it while the process has one thread)."""
    return bool(_libc.unshare(flags) == 0) or _failed(f"unshare {flags:#x}")


def _mount(point: bytes, flags: int) -> bool:
    return bool(_libc.mount(None, point, None, flags, None) == 0)


def _unescape(field: str) -> bytes:
    """A mountinfo path: spaces, tabs, newlines and backslashes are octal escapes."""
    return field.encode().decode("unicode_escape").encode("latin-1")


def read_only_mounts() -> bool:
    """In a mount namespace of this process's own: nothing it does is seen outside, and
    every mount it sees is read-only. Granted when the root is."""
    if not _mount(b"/", MS_REC | MS_PRIVATE):
        return _failed("a private mount namespace")
    with open("/proc/self/mountinfo") as table:
        mounts = [line.split() for line in table]
    root_done = False
    # Deepest first is not needed: a bind remount changes only the mount it names.
    for fields in mounts:
        point, options = _unescape(fields[4]), fields[5].split(",")
        flags = MS_REMOUNT | MS_BIND | MS_RDONLY
        for option in options:
            flags |= KEPT_OPTIONS.get(option, 0)
        if _mount(point, flags):
            root_done = root_done or point == b"/"
    return root_done or _failed("a read-only root")


def no_new_privileges() -> bool:
    """No exec of this process (or any it could start) gains privileges again."""
    return bool(_libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) == 0) or _failed("no_new_privs")


def system_call_filter() -> Any:
    """The filter allowing only the calls in ALLOWED (any other fails with EPERM, and a call
    through another architecture's entry kills the process), for every thread once loaded;
    None where there is no libseccomp. Made ahead: building it takes milliseconds, loading
    it a fraction of one."""
    if pyseccomp is None:
        return None
    try:
        made = pyseccomp.SyscallFilter(pyseccomp.ERRNO(errno.EPERM))
        for name in ALLOWED:
            made.add_rule(pyseccomp.ALLOW, name)
        made.set_attr(pyseccomp.Attr.CTL_TSYNC, 1)
    except OSError as exc:
        log.debug("a system call filter not made: %s", exc)
        return None
    return made


def load(made: Any) -> bool:
    if made is None:
        return _failed("a system call filter (no libseccomp)")
    try:
        made.load()
    except OSError as exc:
        log.debug("a system call filter not granted: %s", exc)
        return False
    return True
