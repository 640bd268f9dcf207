"""Which announced devices to ask to confirm themselves, and when one is gone (issue 31).

Pure bookkeeping over what the DNS-SD cache holds, so it can be followed step by step;
`openpendant.runtime.kit.discovery.Browser` sends the questions and reports the changes. Times are
zeroconf's milliseconds.

A name whose service record lapsed is not forgotten: its confirmations may have been lost
in an outage while the device lived on, and zeroconf, which keeps the pointer record for
19 minutes, would report nothing new when it answers again. It stays asked for, at first
every half second, then at a tenth of how long it has been lost (so an outage's end is
seen within about a tenth of its length, at a cost that grows only with the logarithm of
the time lost), up to 30 s apart, for 30 minutes. A lapsed name whose device has a live
link at its address is not gone (the link proves it is there). A link that comes back is
the network coming back: every lapsed name is asked for at once.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

CONFIRM_FROM = 0.5  # of the TTL: a record older than this is asked to confirm itself…
CONFIRM_EVERY = 0.1  # of the TTL: …and asked again this often until it answers
LOST_FIRST = 500.0  # ms between the first questions for a lapsed name
LOST_GROWTH = 0.1  # then this share of the time it has been lost
LOST_LONGEST = 30_000.0  # ms between questions at most
LOST_KEEP = 30 * 60_000.0  # ms a lapsed name is asked for (its device's link not live)
MAX_LOST = 1024  # lapsed names kept at most (as many as announcements listed)

# The newest live service record of a name: (created, TTL), both in ms; None if none.
NewestRecord = Callable[[str], tuple[float, float] | None]


@dataclass
class Lost:
    since: float
    due: float
    reported: bool = False  # told gone
    vouched: bool = False  # its device's link was live at the last step
    answered: float = 0.0  # when the newest record handed over for resolving was made


@dataclass
class Step:
    ask: list[str] = field(default_factory=list)  # to ask to confirm themselves
    recheck: list[str] = field(default_factory=list)  # lost names answering again: resolve
    gone: list[str] = field(default_factory=list)  # to report gone


class Confirmations:
    def __init__(self) -> None:
        self._asked: dict[str, float] = {}  # confirmed names: when last asked
        self._lost: dict[str, Lost] = {}

    def confirmed(self, name: str, now: float) -> None:
        """Resolved: followed by its records' TTL from now on."""
        if self._lost.pop(name, None) is not None or name not in self._asked:
            self._asked[name] = now

    def unresolved(self, name: str, now: float) -> None:
        """Announced, but its records could not be had: asked for again later."""
        if name not in self._asked and name not in self._lost:
            self._lose(name, Lost(since=now, due=now + LOST_FIRST, reported=True))

    def ended(self, name: str) -> bool:
        """zeroconf's browser saw the name's pointer end (a goodbye, or the end of its
        19 minutes): whether to report it gone now. A lapsed name stays asked for, and is
        reported gone by the sweep once no live link vouches for it."""
        if name in self._lost:
            return False
        self._asked.pop(name, None)
        self._lost.pop(name, None)
        return True

    def is_lost(self, name: str) -> bool:
        return name in self._lost

    def follows(self, name: str) -> bool:
        return name in self._asked or name in self._lost

    def step(self, now: float, newest: NewestRecord, vouched: Callable[[str], bool]) -> Step:
        step = Step()
        for name, asked in list(self._asked.items()):
            record = newest(name)
            if record is None:
                del self._asked[name]
                self._lose(name, Lost(since=now, due=now, vouched=vouched(name)))
                continue
            created, ttl = record
            if now >= created + ttl * CONFIRM_FROM and now - asked >= ttl * CONFIRM_EVERY:
                step.ask.append(name)
                self._asked[name] = now
        returned = False
        for lost_name, lost in self._lost.items():
            live = vouched(lost_name)
            returned = returned or (live and not lost.vouched)
            lost.vouched = live
        for name, lost in list(self._lost.items()):
            if returned:  # a link came back, so did the network: every lapsed name asked now
                lost.due = min(lost.due, now)
            if not lost.vouched and not lost.reported:
                lost.reported = True
                step.gone.append(name)
            if not lost.vouched and now - lost.since >= LOST_KEEP:
                del self._lost[name]
                continue
            record = newest(name)
            if record is not None:
                if record[0] > lost.answered:  # once per answer, resolved or not
                    lost.answered = record[0]
                    step.recheck.append(name)
            elif now >= lost.due:
                step.ask.append(name)
                wait = min(LOST_LONGEST, max(LOST_FIRST, LOST_GROWTH * (now - lost.since)))
                lost.due = now + wait
        return step

    def _lose(self, name: str, lost: Lost) -> None:
        if len(self._lost) >= MAX_LOST:
            # The oldest already told gone: one still listed would never be.
            told = [n for n, lost in self._lost.items() if lost.reported] or list(self._lost)
            del self._lost[min(told, key=lambda n: self._lost[n].since)]
        self._lost[name] = lost
