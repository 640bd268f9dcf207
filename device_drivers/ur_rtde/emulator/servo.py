"""servoj(q, a, v, t, lookahead_time, gain) as the emulated controller runs it.

What UR documents (script manual, servoj): online realtime control of joint positions; each
call moves toward q over t (blocking for t); `lookahead_time` (0.03-0.2 s) "smoothens the
trajectory with this lookahead time", projecting the current position forward with the
current velocity; `gain` (100-2000) is the proportional gain toward q; a and v are unused.
ur-rtde's control script calls it in a loop with the latest target in its registers.

How it is emulated, and why:
- A stream of targets, each to be reached t after the one before, is the path it describes
  sampled every t. A proportional controller on q - (position + lookahead · velocity)
  follows a steady stream exactly `lookahead` behind (its error is zero when position(t) =
  target(t - lookahead)), and it pulls the arm onto the stream when it is off it; its
  transients filter each joint in time, and a time filter on a path that is curved in joint
  space (any straight TCP line) cuts inside it. The stream here is what was planned and
  checked, so the emulated arm follows the quintic interpolation through the targets
  (velocities and accelerations by central differences of the targets: the interpolation
  every driver shares) `lookahead` late (and a little later: see the buffer below), which
  also lets it see the targets after the one it heads for; and where the arm is not on the
  stream (when servoj begins, or after the joint limits held it back) the difference, in
  position, velocity and acceleration, fades out along a quintic over the lookahead. The
  gain has nothing left to do.
- Every target the client sent is taken, in order, each t after the one before (not the
  latest target once every t of the controller's clock, as the script's loop reads it): a
  real client streams in step with the controller's cycle, but here the driver's 8 ms thread
  and the emulator's 2 ms loop share one loaded computer, and the driver now and then sends
  a few targets late (and never catches up) or in a burst; the latest-every-t reading then
  repeats one target and skips the next, a jerk no real-time link gives. So the stream is
  played from a buffer `delay` deep (the lookahead, plus what a client's scheduling may
  lose, `SLACK`), and where the client fell behind far enough to empty it the stream is
  played slower, along its path, through the same time scaling a driver's speed override
  uses (a time filter on the path, rather, would cut inside its curves, and re-timing single
  targets made accelerations of 100 rad/s² that the arm could not follow), and at full speed
  again once the buffer has filled. Never faster than it was sent.
- The reference goes through the arm's tracker: followed exactly within the joint limits,
  and otherwise held under them (the position limits included).
- A target farther from the one before than the joint could go at full speed within t and
  the lookahead is no stream but a jump: a protective stop, as on the real controller."""

from __future__ import annotations

import bisect

import numpy as np

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.robotics.time_scaling import TimeScaling

# Targets either side of the segment played: the central differences of the accelerations
# at both its ends reach two targets beyond each.
REACH = 2
MIN_LOOKAHEAD, MAX_LOOKAHEAD = 0.03, 0.2  # s: the script manual's range
SLACK = 0.1  # s: how late a client's targets may come (in all) before the stream slows
SLOW_ZONE = 0.1  # s: with less of the stream left to play than this, it is played slower
State = tuple[FloatArray, FloatArray, FloatArray]  # position, velocity, acceleration


class ServoJump(RuntimeError):
    """A servoj target the arm cannot reach: the controller stops (protective stop)."""


class ServoJ:
    def __init__(
        self,
        cycle: float,
        max_velocity: FloatArray,
        max_acceleration: FloatArray,
        max_jerk: FloatArray,
    ) -> None:
        self.cycle = cycle
        self.max_velocity = max_velocity
        self._limits = (max_acceleration, max_jerk)
        self.pending: list[tuple[FloatArray, float, float]] = []  # sent, not yet taken
        self.start()

    def command(self, target: FloatArray, period: float, lookahead: float) -> None:
        """A servoj command arrived (every one, in order)."""
        period = max(period, self.cycle)  # nothing is reached sooner than the next cycle
        lookahead = min(max(lookahead, MIN_LOOKAHEAD), MAX_LOOKAHEAD)
        self.pending.append((np.array(target, dtype=float), period, lookahead))

    def start(self) -> None:
        """servoj begins (the targets sent for it are already pending)."""
        self.clock = 0.0  # s: the controller's time since servoj began
        self.lookahead, self.period = MIN_LOOKAHEAD, self.cycle  # the latest target's
        self.tau: float | None = None  # the stream's time being played (0: its first target)
        self.scaling = TimeScaling(*self._limits)  # how fast the stream is played
        self.times: list[float] = []  # when each target is to be reached, on the stream
        self.positions: list[FloatArray] = []
        self._segments: dict[tuple[float, int], tuple[float, FloatArray]] = {}  # by key
        self._played: State | None = None  # the stream as played last cycle
        self._given: State | None = None  # the reference given last cycle (fade included)
        self._fade: tuple[float, FloatArray] | None = None  # since when, and its quintic

    @property
    def delay(self) -> float:
        """How far behind the latest target the stream is played when the client keeps
        time: the lookahead (late enough that the targets after the segment played have
        arrived), and what a client's late targets may take from it before it slows."""
        return max(self.lookahead, (REACH + 1) * self.period) + SLACK

    def step(self, arm: State) -> State:
        """One controller cycle, the arm's tracker at `arm`: the reference to follow."""
        for target, period, lookahead in self.pending:
            self.lookahead, self.period = lookahead, period
            self._take(target, period, lookahead, arm[0])
        self.pending.clear()
        if not self.times:  # no target yet: it holds
            return arm[0].copy(), np.zeros_like(arm[0]), np.zeros_like(arm[0])
        if self.tau is None:
            self.tau = self.times[0] - self.delay
        scaling = self.scaling
        # The stream where it was played last cycle, as it is known now: targets that have
        # arrived since may have changed it there (when it was played to its end).
        rate, rate_speed = scaling.rate, scaling.rate_speed
        now = self._sample(self.tau)
        before = _scaled(now, rate, rate_speed)
        # What may still be played before the segment played lacks the targets after it.
        left = self.times[-1] - (REACH + 1) * self.period - self.tau
        scaling.step(min(1.0, max(0.0, left / SLOW_ZONE)), now[1], now[2], self.cycle)
        self.tau += self.cycle * 0.5 * (rate + scaling.rate)
        self.clock += self.cycle
        played = _scaled(self._sample(self.tau), scaling.rate, scaling.rate_speed)
        moved = self._played is not None and not _same(before, self._played)
        if self._given is None or moved or not _same(self._given, arm):
            # The arm is not where the stream is: from where it is, onto the stream.
            p, v, a = (s - b for s, b in zip(arm, before, strict=True))
            zero = np.zeros_like(p)
            fade = quintic(p, v, a, zero, zero, zero, self.lookahead)
            self._fade = (self.clock - self.cycle, fade)
        self._played = reference = played
        if self._fade is not None:
            since, fade = self._fade
            if self.clock - since >= self.lookahead:
                self._fade = None
            else:
                off = evaluate(fade, self.clock - since)
                reference = (played[0] + off[0], played[1] + off[1], played[2] + off[2])
        self._given = reference
        return reference

    def _take(self, target: FloatArray, period: float, lookahead: float, arm: FloatArray) -> None:
        last = self.positions[-1] if self.positions else arm
        reachable = self.max_velocity * (period + lookahead)
        step = np.abs(target - last)
        if np.any(step > reachable):
            joint = int(np.argmax(step / reachable))
            raise ServoJump(
                f"servoj target out of reach: joint {joint + 1} by {step[joint]:.3f} rad "
                f"in {period:.3f} s"
            )
        self.times.append(self.times[-1] + period if self.times else 0.0)
        self.positions.append(target)

    def _sample(self, tau: float) -> State:
        """The stream at `tau` (before its first target: there, at rest)."""
        if tau <= self.times[0]:
            still = np.zeros_like(self.positions[0])
            return self.positions[0].copy(), still, still.copy()
        k = bisect.bisect_right(self.times, tau) - 1
        if k > REACH + 1:  # what is behind the window (and the one before) is needed no more
            del self.times[: k - REACH - 1], self.positions[: k - REACH - 1]
            k = REACH + 1
        # A segment's ends change only while the targets after it are still coming.
        key = (self.times[k], min(len(self.times) - k, REACH + 2))
        segment = self._segments.get(key)
        if segment is None:
            if len(self._segments) > 8:
                self._segments.clear()
            segment = self._segments[key] = self._coefficients(k)
        h, coefficients = segment
        return evaluate(coefficients, min(tau - self.times[k], h))

    def _coefficients(self, k: int) -> tuple[float, FloatArray]:
        """Segment k's length and its quintic."""
        times, positions = self._window(k)
        # Central differences: the velocity at each target, then the acceleration; at rest
        # until the first target (the stream began there: where a trajectory begins).
        v = (positions[2:] - positions[:-2]) / (times[2:] - times[:-2])[:, None]
        begun = np.arange(k - REACH + 1, k + REACH + 1) > 0  # the window's inner targets
        v[~begun] = 0.0
        a = (v[2:] - v[:-2]) / (times[3:-1] - times[1:-3])[:, None]
        a[~begun[1:-1]] = 0.0
        h = float(times[REACH + 1] - times[REACH])
        p0, p1 = positions[REACH], positions[REACH + 1]
        return h, quintic(p0, v[1], a[0], p1, v[2], a[1], h)

    def _window(self, k: int) -> tuple[FloatArray, FloatArray]:
        """The targets k - REACH … k + REACH + 1; before the first and after the last the
        stream stands still (its end repeated, a cycle apart)."""
        n = len(self.times)
        times, positions = [], []
        for j in range(k - REACH, k + REACH + 2):
            c = min(max(j, 0), n - 1)
            times.append(self.times[c] + (j - c) * self.cycle)
            positions.append(self.positions[c])
        return np.array(times), np.array(positions)


def quintic(
    p0: FloatArray,
    v0: FloatArray,
    a0: FloatArray,
    p1: FloatArray,
    v1: FloatArray,
    a1: FloatArray,
    h: float,
) -> FloatArray:
    """The coefficients (of s⁰ … s⁵, a row each) of the quintic from (p0, v0, a0) to
    (p1, v1, a1) over h: the one polynomial with these ends, so the interpolation of
    runtime/robotics/reference.py, in closed form (one sample a cycle costs a tenth)."""
    d = p1 - p0
    return np.array(
        [
            p0,
            v0,
            a0 / 2,
            (20 * d - (8 * v1 + 12 * v0) * h - (3 * a0 - a1) * h * h) / (2 * h**3),
            (-30 * d + (14 * v1 + 16 * v0) * h + (3 * a0 - 2 * a1) * h * h) / (2 * h**4),
            (12 * d - 6 * (v1 + v0) * h - (a0 - a1) * h * h) / (2 * h**5),
        ]
    )


def evaluate(coefficients: FloatArray, s: float) -> State:
    """Position, velocity and acceleration of a quintic at s."""
    powers = np.array(
        [
            [1.0, s, s**2, s**3, s**4, s**5],
            [0.0, 1.0, 2 * s, 3 * s**2, 4 * s**3, 5 * s**4],
            [0.0, 0.0, 2.0, 6 * s, 12 * s**2, 20 * s**3],
        ]
    )
    p, v, a = powers @ coefficients
    return p, v, a


def _scaled(state: State, rate: float, rate_speed: float) -> State:
    """The stream's state played at `rate` (changing by `rate_speed` per second)."""
    p, v, a = state
    return p, v * rate, a * rate * rate + v * rate_speed


def _same(one: State, other: State) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(one, other, strict=True))
