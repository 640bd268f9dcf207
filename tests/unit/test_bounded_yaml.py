"""YAML from outside is measured before it is built: what an honest document holds comes out
as PyYAML's safe loader gives it; aliases that would build more values than the document has
bytes (and a margin), a document containing itself, and nesting past the limit are refused
with the reason, before a single value is built."""

from __future__ import annotations

from typing import Any

import pytest
import yaml

from openpendant.runtime.kit import bounded_yaml
from openpendant.runtime.kit.bounded_yaml import SPARE_VALUES, YamlRefused, load_yaml

HONEST = [
    "variables:\n- name: wp1\n  type: joint_waypoint\n  value: [0.1, -1.2, 1.5, 0, 1.57, 0]\n",
    "defaults: &d {speed: 0.25, blend: 0.01}\nmoves:\n- {<<: *d, to: a}\n- {<<: *d, to: b}\n",
    "same: &s [1, 2, 3]\nagain: [*s, *s, *s]\n",
    "just text",
    "",
    "- - - - - deep but fine\n",
]


@pytest.mark.parametrize("document", HONEST)
def test_an_honest_document_reads_as_the_safe_loader_reads_it(document: str) -> None:
    assert load_yaml(document) == yaml.safe_load(document)
    assert load_yaml(document.encode()) == yaml.safe_load(document)


def laughs(levels: int, width: int = 9) -> str:
    """`levels` lists, each of `width` aliases of the one before: width**levels values."""
    first = f"l0: &l0 [{', '.join(['lol'] * width)}]\n"
    return first + "".join(
        f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * width)}]\n" for i in range(1, levels)
    )


REFUSED = {
    "billion laughs": (laughs(9), "values"),
    "two levels, wide": (laughs(2, width=400), "values"),
    "contains itself": ("a: &a [1, *a]\n", "itself"),
    "contains itself in a mapping": ("a: &a {k: *a}\n", "itself"),
    "nested too deep": ("[" * 101 + "]" * 101, "deeper"),
}


@pytest.mark.parametrize(("document", "why"), REFUSED.values(), ids=REFUSED.keys())
def test_a_document_outside_the_bounds_is_refused_before_anything_is_built(
    monkeypatch: pytest.MonkeyPatch, document: str, why: str
) -> None:
    built: list[Any] = []
    original = bounded_yaml.SAFE_LOADER.construct_document

    def construct(self: Any, node: yaml.Node) -> Any:
        built.append(node)
        return original(self, node)

    monkeypatch.setattr(bounded_yaml.SAFE_LOADER, "construct_document", construct)
    with pytest.raises(YamlRefused, match=why):
        load_yaml(document)
    assert built == []


def test_the_bound_grows_with_the_document() -> None:
    """Aliases may build as many values as the document has bytes, and a margin: a big
    honest export with a few aliases is not refused for its size."""
    two_levels = laughs(2, width=300)  # 300 + 300 * 300 values
    assert len(two_levels) + SPARE_VALUES > 300 * 300
    assert len(load_yaml(two_levels)["l1"]) == 300


def test_not_yaml_is_a_yaml_error() -> None:
    with pytest.raises(yaml.YAMLError):
        load_yaml("- [a, b\n")
