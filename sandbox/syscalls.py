"""The kernel's own walls around a worker, each taken where the system grants it: namespaces,
a read-only view of the files, no new privileges and a seccomp filter. Every function says
whether it was granted; none raises, so a host without one still runs programs, and the run
reports what it had (`isolation`)."""

from __future__ import annotations

import ctypes
import errno
import logging

log = logging.getLogger(__name__)

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
# rt_sigreturn), with the calls the interpreter makes on paths those runs did not take, and
# their 32-bit spellings (mmap2, _llseek, fstat64, the *_time64 clocks).
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
    "mmap2",
    "_llseek",
    "fstat64",
    "clock_gettime64",
    "clock_nanosleep_time64",
    "clock_getres_time64",
    "futex_time64",
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


# libseccomp (Debian's libseccomp2, there wherever apt or systemd is) builds the filter's
# BPF for this architecture. Its five calls are bound here by name: the PyPI bindings look
# the library up with ctypes.util.find_library, which runs `ldconfig -p` twice in every new
# worker (about 17 ms of its start).
SCMP_ACT_ALLOW = 0x7FFF0000
SCMP_ACT_KILL_PROCESS = 0x80000000
SCMP_FLTATR_ACT_BADARCH = 2
SCMP_FLTATR_CTL_TSYNC = 4
NR_SCMP_ERROR = -1  # a name libseccomp does not know on any architecture


def scmp_act_errno(code: int) -> int:
    return 0x00050000 | (code & 0xFFFF)


def _libseccomp() -> ctypes.CDLL | None:
    try:
        lib = ctypes.CDLL("libseccomp.so.2", use_errno=True)
    except OSError:
        return None
    lib.seccomp_init.restype = ctypes.c_void_p
    lib.seccomp_init.argtypes = [ctypes.c_uint32]
    lib.seccomp_syscall_resolve_name.restype = ctypes.c_int
    lib.seccomp_syscall_resolve_name.argtypes = [ctypes.c_char_p]
    lib.seccomp_rule_add_array.restype = ctypes.c_int
    lib.seccomp_rule_add_array.argtypes = [
        ctypes.c_void_p,
        ctypes.c_uint32,
        ctypes.c_int,
        ctypes.c_uint,
        ctypes.c_void_p,
    ]
    lib.seccomp_attr_set.restype = ctypes.c_int
    lib.seccomp_attr_set.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_uint32]
    lib.seccomp_load.restype = ctypes.c_int
    lib.seccomp_load.argtypes = [ctypes.c_void_p]
    return lib


_seccomp = _libseccomp()


def system_call_filter() -> int | None:
    """The filter allowing only the calls in ALLOWED (any other fails with EPERM, and a call
    through another architecture's entry kills the process), for every thread once loaded;
    None where libseccomp is missing or refuses. Made ahead: building it takes a millisecond
    or so, loading it a fraction of one."""
    if _seccomp is None:
        return None
    made: int | None = _seccomp.seccomp_init(scmp_act_errno(errno.EPERM))
    if not made:
        return None
    for name in ALLOWED:
        # Negative numbers other than the error are libseccomp's for calls this
        # architecture lacks (mmap on i386): allowed as such, never an error.
        number = _seccomp.seccomp_syscall_resolve_name(name.encode())
        if number == NR_SCMP_ERROR:
            log.debug("libseccomp does not know %s", name)
            continue
        if _seccomp.seccomp_rule_add_array(made, SCMP_ACT_ALLOW, number, 0, None):
            log.debug("the filter cannot allow %s", name)
            return None
    # A call through another architecture's entry ends the whole process, not one thread
    # (a thread left alone would hold the run open).
    for attribute, value in (
        (SCMP_FLTATR_ACT_BADARCH, SCMP_ACT_KILL_PROCESS),
        (SCMP_FLTATR_CTL_TSYNC, 1),
    ):
        if _seccomp.seccomp_attr_set(made, attribute, value):
            return None
    return made


def load(made: int | None) -> bool:
    """The filter in force for this process and every thread of it (it stays for good)."""
    if _seccomp is None or made is None:
        return _failed("a system call filter (no libseccomp)")
    failed = _seccomp.seccomp_load(made)
    return failed == 0 or _failed(f"a system call filter (libseccomp: {failed})")
