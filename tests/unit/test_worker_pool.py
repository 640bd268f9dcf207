"""The program service's worker pool: a spare is started ahead, but not at once after one is
taken (its start-up would compete with the run's first move), and closing the pool leaves
no worker process behind, even with a refill still pending."""

from __future__ import annotations

import asyncio
import os
from pathlib import Path

import pytest

from openpendant.runtime.auth.setup import SETUP_CODE_ENV
from openpendant.runtime.drivers.run import SECRET_ENV
from openpendant.runtime.kit.internal import ENV as INTERNAL_ENV
from openpendant.sandbox.protocol import FUNCTIONS_ENV
from openpendant.sandbox.supervisor import (
    REFILL_DELAY,
    WORKER_PASSES,
    WorkerPool,
    spawn_worker,
    worker_env,
)

LIMITS = '{"cpu_seconds": 60, "memory_mb": 256}'


def workers() -> set[int]:
    """This process's children that are sandbox workers."""
    found = set()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            command = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        parent = int(stat.rsplit(")", 1)[1].split()[1])
        if parent == os.getpid() and b"sandbox.worker" in command:
            found.add(int(entry.name))
    return found


def environ_of(pid: int) -> bytes:
    return Path(f"/proc/{pid}/environ").read_bytes()


async def settle(pool: WorkerPool, taken: list[int]) -> set[int]:
    await pool.close()
    for pid in taken:
        os.kill(pid, 9)
    for _ in range(50):
        await asyncio.sleep(0.05)
        left = {pid for pid in workers() if pid not in taken}
        if not left:
            return left
    return left


def test_a_spare_is_started_after_a_delay_and_handed_out_next() -> None:
    async def go() -> None:
        pool = WorkerPool()
        first = await pool.take(LIMITS)
        await asyncio.sleep(REFILL_DELAY / 2)
        assert workers() == {first.pid}  # no spare yet while the first run starts
        await asyncio.sleep(REFILL_DELAY / 2 + 1.0)
        spares = workers() - {first.pid}
        assert len(spares) == 1
        second = await pool.take(LIMITS)
        assert {second.pid} == spares
        assert await settle(pool, [first.pid, second.pid]) == set()
        await first.wait()
        await second.wait()

    asyncio.run(go())


def test_closing_with_a_refill_pending_leaves_no_worker() -> None:
    async def go() -> None:
        pool = WorkerPool()
        first = await pool.take(LIMITS)
        second = await pool.take(LIMITS)  # within the delay: started at once, refill pending
        assert await settle(pool, [first.pid, second.pid]) == set()
        await asyncio.sleep(REFILL_DELAY + 0.5)
        assert workers() - {first.pid, second.pid} == set()
        await first.wait()
        await second.wait()

    asyncio.run(go())


def test_a_worker_is_given_none_of_the_runtimes_secrets(monkeypatch: pytest.MonkeyPatch) -> None:
    """A worker's environment is built from nothing: the internal token that opens every
    service, the set-up code and a device's secret are not in it, only where Python finds its
    packages and the plugins' sandbox functions."""
    secrets = {
        INTERNAL_ENV: "internal-token-value",
        SETUP_CODE_ENV: "set-up-code-value",
        SECRET_ENV: "device-secret-value",
        "OPENPENDANT_DATA_DIR": "/somewhere",
    }
    for name, value in secrets.items():
        monkeypatch.setenv(name, value)
    monkeypatch.setenv("PYTHONPATH", "/plugins/here")
    worker_env.cache_clear()

    async def go() -> bytes:
        process = await spawn_worker(LIMITS)
        try:
            return environ_of(process.pid)
        finally:
            process.kill()
            await process.wait()

    try:
        given = dict(
            entry.split("=", 1) for entry in asyncio.run(go()).decode().split("\0") if entry
        )
    finally:
        worker_env.cache_clear()
    assert set(given) <= {"PATH", FUNCTIONS_ENV, *WORKER_PASSES}
    assert given["PYTHONPATH"] == "/plugins/here"
    assert not any(value in given.values() for value in secrets.values())
