"""The I/O of a UR controller as an I/O block (`openpendant driver ur-io --address HOST`), so
programs, the I/O panel and the blocks use it as they use a Modbus block: the standard,
configurable and tool digital inputs and outputs and the standard analog ones, named as
PolyScope labels them (di0-di7, ci0-ci7, ti0-ti1; do0-do7, co0-co7, to0-to1; ai0-ai1,
ao0-ao1).

Read from an RTDE receive connection of its own (a thread: ur-rtde's calls hold the
interpreter lock while they wait on the network); written through ur-rtde's I/O interface and
confirmed only when the controller's own state shows the value written. While the
controller does not answer, every signal is unknown (None), never the last value it had."""

from __future__ import annotations

import asyncio
import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any, Literal

import rtde_receive

from openpendant.device_drivers.ur_rtde.io_writer import OutputWriter
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.io import (
    IODriver,
    IOInfo,
    SignalInfo,
    SignalReading,
    SignalRecord,
    SignalValue,
    SignalWrite,
)
from openpendant.runtime.kit.errors import InvalidValue, NotFound, OpenPendantError, Unavailable

log = logging.getLogger(__name__)

Domain = Literal["voltage", "current"]
# (input prefix, output prefix, first bit in the controller's digital bits, count, where)
BANKS = (
    ("di", "do", 0, 8, "standard"),
    ("ci", "co", 8, 8, "configurable"),
    ("ti", "to", 16, 2, "tool"),
)
RANGES: dict[Domain, tuple[str, float, float]] = {
    "voltage": ("V", 0.0, 10.0),
    "current": ("mA", 4.0, 20.0),
}
RECIPE = [
    "timestamp",
    "actual_digital_input_bits",
    "actual_digital_output_bits",
    "standard_analog_input0",
    "standard_analog_input1",
    "standard_analog_output0",
    "standard_analog_output1",
]
RECONNECT_AFTER = 1.0  # s between two connection attempts
CONFIRM_WITHIN = 1.0  # s for a written value to show in the controller's state
ANALOG_TOLERANCE = 0.005  # of the range: a written analog output counts as confirmed


def signals(analog_inputs: Domain, analog_outputs: Domain) -> list[SignalInfo]:
    found: list[SignalInfo] = []
    for kind, index in (("input", 0), ("output", 1)):
        for bank in BANKS:
            prefix, count, where = bank[index], bank[3], bank[4]
            found += [
                SignalInfo(
                    name=f"{prefix}{k}",
                    kind="digital_input" if kind == "input" else "digital_output",
                    description=f"{where} digital {kind} {k}",
                )
                for k in range(count)
            ]
    for prefix, kind, domain in (("ai", "input", analog_inputs), ("ao", "output", analog_outputs)):
        unit, low, high = RANGES[domain]
        found += [
            SignalInfo(
                name=f"{prefix}{k}",
                kind="analog_input" if kind == "input" else "analog_output",
                unit=unit,
                minimum=low,
                maximum=high,
                description=f"standard analog {kind} {k} ({domain})",
            )
            for k in range(2)
        ]
    return found


def read_values(receive: Any) -> dict[str, SignalValue]:
    inputs = int(receive.getActualDigitalInputBits())
    outputs = int(receive.getActualDigitalOutputBits())
    values: dict[str, SignalValue] = {}
    for in_prefix, out_prefix, first, count, _ in BANKS:
        for k in range(count):
            values[f"{in_prefix}{k}"] = bool(inputs >> (first + k) & 1)
            values[f"{out_prefix}{k}"] = bool(outputs >> (first + k) & 1)
    values["ai0"] = float(receive.getStandardAnalogInput0())
    values["ai1"] = float(receive.getStandardAnalogInput1())
    values["ao0"] = float(receive.getStandardAnalogOutput0())
    values["ao1"] = float(receive.getStandardAnalogOutput1())
    return values


class URIODriver(SignalRecord, IODriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        host: str,
        *,
        analog_inputs: Domain = "voltage",
        analog_outputs: Domain = "voltage",
        frequency: float = 125.0,
        poll_hz: float = 100.0,
        clock: Callable[[], float] = time.time,
    ) -> None:
        info = IOInfo(
            model="Universal Robots controller I/O", signals=signals(analog_inputs, analog_outputs)
        )
        super().__init__(identity, info)
        self.host, self.frequency, self.period = host, frequency, 1.0 / poll_hz
        self.analog_outputs = analog_outputs
        self.signals = {s.name: s for s in info.signals}
        self._start_record(self.signals, clock)
        self._published = asyncio.Condition()  # a write waits on it for its read-back
        self._writing = asyncio.Lock()  # one write at a time, each confirmed before the next
        self.writer = OutputWriter(host)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # The reading thread -------------------------------------------------------------------

    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._thread = threading.Thread(target=self._run, name="ur-io", daemon=True)
        self._thread.start()

    async def shutdown(self) -> None:
        self._stop.set()
        if self._thread is not None:
            await asyncio.to_thread(self._thread.join, 5.0)
        await self.writer.close()

    def _run(self) -> None:
        receive: Any = None
        last: tuple[dict[str, SignalValue], bool, str] | None = None
        while not self._stop.is_set():
            if receive is None:
                receive = self._connect()
                if receive is None:
                    self._stop.wait(RECONNECT_AFTER)
                    continue
            try:
                if not receive.isConnected():
                    raise ConnectionError("the controller closed the connection")
                now: tuple[dict[str, SignalValue], bool, str] = (read_values(receive), True, "")
            except Exception as exc:
                why = f"lost the connection to the controller at {self.host}: {exc}"
                log.warning("%s", why)
                _close(receive)
                receive = None
                now = (dict.fromkeys(self.signals), False, why)
            if now != last:
                self._publish(*now)
                last = now
            self._stop.wait(self.period)
        if receive is not None:
            _close(receive)

    def _connect(self) -> Any:
        try:
            return rtde_receive.RTDEReceiveInterface(self.host, self.frequency, RECIPE)
        except Exception as exc:
            why = f"cannot reach the controller at {self.host}: {exc}"
            if why != self.error:
                log.warning("%s", why)
            self._publish(dict.fromkeys(self.signals), False, why)
            return None

    def _publish(self, values: dict[str, SignalValue], connected: bool, error: str) -> None:
        """From the reading thread: the state changes in the event loop's thread only."""
        loop = self._loop
        if loop is not None and not loop.is_closed():
            asyncio.run_coroutine_threadsafe(self._update(values, connected, error), loop)

    async def _update(self, values: dict[str, SignalValue], connected: bool, error: str) -> None:
        self._record(values, connected=connected, error=error)
        async with self._published:
            self._published.notify_all()

    # The I/O interface --------------------------------------------------------------------

    def _signal(self, name: str) -> SignalInfo:
        try:
            return self.signals[name]
        except KeyError:
            raise NotFound(f"no signal {name!r}", code="unknown_signal") from None

    def _reachable(self) -> None:
        if not self.connected:
            raise Unavailable(self.error or f"not connected to {self.host}", code="disconnected")

    async def read(self, name: str) -> SignalReading:
        self._signal(name)
        self._reachable()
        return SignalReading(name=name, value=self.values[name], ts=self.clock())

    async def write(self, name: str, command: SignalWrite) -> SignalReading:
        signal = self._signal(name)
        if not signal.writable:
            raise InvalidValue(f"{name} is an input: only outputs are written", code="read_only")
        call, args = self._call(signal, command.value)
        async with self._writing:
            self._reachable()
            await self.writer.call(call, *args)
            value = await self._read_back(signal, command.value)
        return SignalReading(name=name, value=value, ts=self.clock())

    def _call(
        self, signal: SignalInfo, value: bool | float
    ) -> tuple[str, tuple[int, bool | float]]:
        """ur-rtde's I/O interface method that writes it, and its arguments."""
        index = int(signal.name[2:])
        if signal.digital:
            if not isinstance(value, bool):
                raise InvalidValue(f"{signal.name} is digital: write true or false")
            method = {"do": "setStandardDigitalOut", "co": "setConfigurableDigitalOut"}.get(
                signal.name[:2], "setToolDigitalOut"
            )
            return method, (index, value)
        low, high = _range(signal)
        if isinstance(value, bool) or not math.isfinite(value):
            raise InvalidValue(f"{signal.name} is analog: write a finite number")
        if not low <= value <= high:
            raise InvalidValue(f"{signal.name} takes {low:g} to {high:g} {signal.unit}")
        ratio = (value - low) / (high - low)  # the controller takes a ratio of the range
        if self.analog_outputs == "voltage":
            return "setAnalogOutputVoltage", (index, ratio)
        return "setAnalogOutputCurrent", (index, ratio)

    def _holds(self, signal: SignalInfo, wanted: bool | float) -> bool:
        value = self.values[signal.name]
        if value is None or isinstance(value, bool) or isinstance(wanted, bool):
            return value == wanted
        low, high = _range(signal)
        return abs(value - wanted) <= ANALOG_TOLERANCE * (high - low)

    async def _read_back(self, signal: SignalInfo, wanted: bool | float) -> SignalValue:
        deadline = time.monotonic() + CONFIRM_WITHIN
        async with self._published:
            while not self._holds(signal, wanted):
                left = deadline - time.monotonic()
                if left <= 0 or not self.connected:
                    raise OpenPendantError(
                        f"{signal.name}: wrote {wanted}, the controller holds "
                        f"{self.values[signal.name]}",
                        code="not_confirmed",
                        status=502,
                    )
                try:
                    async with asyncio.timeout(left):
                        await self._published.wait()
                except TimeoutError:
                    continue
        return self.values[signal.name]


def _range(analog: SignalInfo) -> tuple[float, float]:
    low, high = analog.minimum, analog.maximum
    if low is None or high is None:
        raise ValueError(f"{analog.name} has no range")  # every analog signal here has one
    return low, high


def _close(receive: Any) -> None:
    try:
        receive.disconnect()
    except Exception as exc:
        log.debug("closing the receive connection: %s", exc)
