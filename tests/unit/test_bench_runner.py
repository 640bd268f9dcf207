"""Which figures `openpendant bench --only …` reports: every figure of a benchmark named,
only the named figures of the others (a benchmark may share its name with one of its
figures, as cold_start does)."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest

from runtime.bench import runner
from runtime.bench.runner import Figure


def fake(*names: str) -> SimpleNamespace:
    return SimpleNamespace(FIGURES=names, run=lambda: [Figure(n, 1.0, "s") for n in names])


def test_a_benchmark_named_reports_all_its_figures_a_figure_named_only_itself(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    modules = {"cold_start": fake("cold_start", "total_pss"), "jog": fake("jog_a", "jog_b")}
    monkeypatch.setattr(runner, "MODULES", tuple(modules))
    monkeypatch.setattr(runner, "load", modules.__getitem__)
    out = tmp_path / "figures.json"
    runner.main(["cold_start", "jog_b"], out)
    assert sorted(k for k in json.loads(out.read_text()) if k != "_meta") == [
        "cold_start",
        "jog_b",
        "total_pss",
    ]
