"""The program service's worker pool: a spare is started ahead, but not at once after one is
taken (its start-up would compete with the run's first move), and closing the pool leaves
no worker process behind, even with a refill still pending."""

from __future__ import annotations

import asyncio
import os
from pathlib import Path

from openpendant.sandbox.supervisor import REFILL_DELAY, WorkerPool

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
