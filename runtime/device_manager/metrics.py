"""The links' figures for the plant's monitoring (runtime/kit/metrics.py), read from the
registry at each scrape: whether each device's link is up, how old its newest state is, how
many states it sent (their rate is its state rate) and how often it entered a protective
stop."""

from __future__ import annotations

from collections.abc import Iterator

from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, Metric
from prometheus_client.registry import Collector

from openpendant.runtime.device_manager.registry import DeviceRegistry, state_age


class LinkCollector(Collector):
    def __init__(self, registry: DeviceRegistry) -> None:
        self.registry = registry

    def collect(self) -> Iterator[Metric]:
        up = GaugeMetricFamily(
            "openpendant_device_link_up",
            "1 while the device's link is connected (0: connecting, stale or disconnected)",
            labels=["device", "kind"],
        )
        age = GaugeMetricFamily(
            "openpendant_device_state_age_seconds",
            "How old the device's newest state is (connected devices only)",
            labels=["device"],
        )
        states = CounterMetricFamily(
            "openpendant_device_states",
            "States received from the device (their rate is its state rate)",
            labels=["device"],
        )
        stops = CounterMetricFamily(
            "openpendant_protective_stops",
            "Times the device's state entered a protective stop",
            labels=["device"],
        )
        for name, conn in sorted(self.registry.connections.items()):
            up.add_metric([name, conn.record.kind], 1.0 if conn.status == "connected" else 0.0)
            seconds = state_age(conn)
            if seconds is not None:
                age.add_metric([name], seconds)
            states.add_metric([name], conn.states_received)
            stops.add_metric([name], conn.protective_stops)
        yield from (up, age, states, stops)
