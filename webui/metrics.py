"""`GET /metrics` on the UI's port: every service's series (runtime/kit/metrics.py) and the
gateway's own in one Prometheus exposition, each sample labelled with the service it came
from, and `openpendant_service_up` saying which answered. Readable by any signed-in role and
by an API token (a viewer's is enough for Prometheus: `bearer_token` in its scrape config)."""

from __future__ import annotations

import asyncio
from collections.abc import Iterable, Iterator

import httpx
from prometheus_client import REGISTRY, CollectorRegistry, generate_latest
from prometheus_client.core import GaugeMetricFamily, Metric
from prometheus_client.parser import text_string_to_metric_families
from prometheus_client.registry import Collector

TIMEOUT = 2.0  # s a service has to answer


class Gathered(Collector):
    def __init__(self, families: Iterable[Metric]) -> None:
        self.families = list(families)

    def collect(self) -> Iterator[Metric]:
        yield from self.families


def labelled(service: str, families: Iterable[Metric], into: dict[str, Metric]) -> None:
    """`families` merged into `into` (by name), each sample labelled with `service`."""
    for family in families:
        merged = into.setdefault(
            family.name, Metric(family.name, family.documentation, family.type, family.unit)
        )
        for sample in family.samples:
            merged.add_sample(
                sample.name,
                {**sample.labels, "service": service},
                sample.value,
                sample.timestamp,
                sample.exemplar,
            )


async def scrape(http: httpx.AsyncClient, url: str) -> str | None:
    try:
        answer = await http.get(f"{url}/metrics", timeout=TIMEOUT)
    except httpx.HTTPError:
        return None
    return answer.text if answer.status_code == 200 else None


async def gathered(http: httpx.AsyncClient, urls: dict[str, str]) -> bytes:
    texts = await asyncio.gather(*(scrape(http, url) for url in urls.values()))
    families: dict[str, Metric] = {}
    up = GaugeMetricFamily(
        "openpendant_service_up", "1 when the service answered this scrape", labels=["service"]
    )
    own = text_string_to_metric_families(generate_latest(REGISTRY).decode())
    labelled("webui", own, families)
    up.add_metric(["webui"], 1.0)
    for name, text in zip(urls, texts, strict=True):
        try:
            parsed = list(text_string_to_metric_families(text)) if text is not None else None
        except ValueError:  # a service that answered nonsense is counted as down
            parsed = None
        up.add_metric([name], 0.0 if parsed is None else 1.0)
        if parsed is not None:
            labelled(name, parsed, families)
    exposition = CollectorRegistry(auto_describe=False)
    exposition.register(Gathered([up, *families.values()]))
    return generate_latest(exposition)
