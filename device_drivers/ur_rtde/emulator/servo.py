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
  every driver shares) `lookahead` late, which also lets it see the targets after the one
  it heads for; and where the arm is not on the stream (when servoj begins, or after the
  joint limits held it back) the difference, in position, velocity and acceleration, fades
  out along a quintic over the lookahead. The gain has nothing left to do.
- Every target the client sent is taken, in order, each t after the one before (not the
  latest target once every t of the controller's clock, as the script's loop reads it): a
  real client streams in step with the controller's cycle, but here the driver's 8 ms thread
  and the emulator's 2 ms loop, on one loaded computer, are a few milliseconds apart now and
  then; the latest-every-t reading then repeats one target and skips the next, a jerk no
  real-time link gives. The two clocks drifting apart by more than the lookahead re-times
  the stream there (it is neither run through faster nor left behind).
- The reference goes through the arm's tracker: followed exactly within the joint limits,
  and otherwise held under them (the position limits included).
- A target farther from the one before than the joint could go at full speed within t and
  the lookahead is no stream but a jump: a protective stop, as on the real controller."""

from __future__ import annotations

import bisect

import numpy as np

from runtime.interfaces.limits import FloatArray

# Targets either side of the segment played: the central differences of the accelerations
# at both its ends reach two targets beyond each.
REACH = 2
MIN_LOOKAHEAD, MAX_LOOKAHEAD = 0.03, 0.2  # s: the script manual's range
State = tuple[FloatArray, FloatArray, FloatArray]  # position, velocity, acceleration


class ServoJump(RuntimeError):
    """A servoj target the arm cannot reach: the controller stops (protective stop)."""


class ServoJ:
    def __init__(self, cycle: float, max_velocity: FloatArray) -> None:
        self.cycle = cycle
        self.max_velocity = max_velocity
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
        self.delay = MIN_LOOKAHEAD  # s: how far behind that clock the stream is played
        self.times: list[float] = []  # when each target is to be reached
        self.positions: list[FloatArray] = []
        self._key: tuple[float, int] | None = None  # the segment being played, and its
        self._segment: tuple[float, FloatArray] = (0.0, np.zeros(0))  # length and quintic
        self._played: State | None = None  # the stream where it was played last cycle
        self._given: State | None = None  # the reference given last cycle
        self._fade: tuple[float, FloatArray] | None = None  # since when, and its quintic

    def step(self, arm: State) -> State:
        """One controller cycle, the arm's tracker at `arm`: the reference to follow."""
        for target, period, lookahead in self.pending:
            # Late enough that the targets after the segment played have arrived.
            self.delay = max(lookahead, (REACH + 1) * period)
            self._take(target, period, lookahead, arm[0])
        self.pending.clear()
        if not self.times:  # no target yet: it holds
            return arm[0].copy(), np.zeros_like(arm[0]), np.zeros_like(arm[0])
        before = self._played or self._sample(self.clock - self.delay)
        self.clock += self.cycle
        played = self._played = self._sample(self.clock - self.delay)
        given = self._given
        if given is None or not all(np.array_equal(g, s) for g, s in zip(given, arm, strict=True)):
            # The arm is not where it was sent: from where it is, onto the stream.
            p, v, a = (s - b for s, b in zip(arm, before, strict=True))
            zero = np.zeros_like(p)
            self._fade = (self.clock - self.cycle, quintic(p, v, a, zero, zero, zero, self.delay))
        reference = played
        if self._fade is not None:
            since, fade = self._fade
            if self.clock - since >= self.delay:
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
        if not self.times:
            due = self.clock + period
        else:  # re-timed where the clocks drifted apart, but always after the one before
            played = self.clock - self.delay
            due = min(max(self.times[-1] + period, played + period), self.clock + self.delay)
            due = max(due, self.times[-1] + self.cycle)
        self.times.append(due)
        self.positions.append(target)

    def _sample(self, tau: float) -> State:
        """The stream at `tau` (before its first target: there, at rest)."""
        if tau <= self.times[0]:
            still = np.zeros_like(self.positions[0])
            return self.positions[0].copy(), still, still.copy()
        k = bisect.bisect_right(self.times, tau) - 1
        if k > REACH:  # what is behind the window is needed no more
            del self.times[: k - REACH], self.positions[: k - REACH]
            k = REACH
        # A segment's ends change only while the targets after it are still coming.
        key = (self.times[k], min(len(self.times) - k, REACH + 2))
        if key != self._key:
            self._key, self._segment = key, self._coefficients(k)
        h, coefficients = self._segment
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
