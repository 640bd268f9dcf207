"""A task that swallows a cancel (as Python 3.11's wait_for does when the result comes in
the same loop round) is still ended."""

from __future__ import annotations

import asyncio

import pytest

from openpendant.runtime.kit.tasks import cancel_for_sure

pytestmark = pytest.mark.concurrent


def test_a_task_that_swallows_a_cancel_is_ended_all_the_same() -> None:
    rounds = 0

    async def stubborn() -> None:
        nonlocal rounds
        swallowed = False
        while True:
            rounds += 1
            try:
                await asyncio.sleep(0.01)
            except asyncio.CancelledError:
                if swallowed:
                    raise
                swallowed = True  # the first one, as wait_for would

    async def main() -> asyncio.Task[None]:
        task = asyncio.create_task(stubborn())
        await asyncio.sleep(0.05)
        await cancel_for_sure(task)
        return task

    task = asyncio.run(main())
    assert task.cancelled() and rounds > 1


def test_a_task_that_ends_with_an_error_is_ended_quietly() -> None:
    async def failing() -> None:
        try:
            await asyncio.sleep(10)
        finally:
            raise RuntimeError("its own")

    async def main() -> asyncio.Task[None]:
        task = asyncio.create_task(failing())
        await asyncio.sleep(0)
        await cancel_for_sure(task)
        return task

    task = asyncio.run(main())
    assert isinstance(task.exception(), RuntimeError)
