"""Claims: who a command is for. A program run claims its robots on its service's link to
the device manager under the run's id; the motion service's commands for that run carry the
same id. A claim ends when its run unclaims or when the service that made it goes away
(its link closes), and a command under an ended claim never reaches a device: the caller
that asked for it is gone. (The lease alone outlives a killed service by seconds.)"""

from __future__ import annotations

import asyncio
from collections import OrderedDict

# A claim a command names may still be on its way on the claimant's own socket (the run
# claims its robot while its first move is planned): this long is waited for it.
CLAIM_WAIT = 1.0  # s
CLAIM_POLL = 0.01  # s
KEEP_ENDED = 10_000
MAX_CLAIM = 64  # characters


class Claims:
    def __init__(self) -> None:
        self._owners: dict[str, object] = {}  # claim -> the link that made it
        self._ended: OrderedDict[str, None] = OrderedDict()

    def take(self, claim: str, owner: object) -> None:
        if claim not in self._ended:
            self._owners[claim] = owner

    def end(self, claim: str) -> None:
        self._owners.pop(claim, None)
        self._ended[claim] = None
        while len(self._ended) > KEEP_ENDED:
            self._ended.popitem(last=False)

    def end_all(self, owner: object) -> list[str]:
        """Every claim `owner` made, ended (its link closed); the ones that were live."""
        ended = [claim for claim, who in self._owners.items() if who is owner]
        for claim in ended:
            self.end(claim)
        return ended

    def live(self, claim: str) -> bool:
        return claim in self._owners

    def owner(self, claim: str) -> object | None:
        return self._owners.get(claim)

    async def wait_live(self, claim: str, timeout: float = CLAIM_WAIT) -> bool:
        """True once the claim is live; False when it has ended or never came."""
        deadline = asyncio.get_running_loop().time() + timeout
        while claim not in self._owners:
            if claim in self._ended or asyncio.get_running_loop().time() >= deadline:
                return False
            await asyncio.sleep(CLAIM_POLL)
        return True
