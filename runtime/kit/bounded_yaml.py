"""YAML from outside (an import, an uploaded file) read within bounds. PyYAML's safe loader
builds what a document's aliases point to once per alias: a few hundred bytes of nested
aliases (a "billion laughs") expand to billions of values, minutes of CPU and gigabytes. The
document is composed first (aliases stay references, linear in its size), measured as it
would be built, and built only within the bounds. Parsed by libyaml where PyYAML has it:
PyYAML's own scanner takes seconds for a few thousand nested brackets (it looks back over
every open level at each token), libyaml milliseconds, and it refuses beyond 1000 levels."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any, cast

import yaml

# Values a document may build, beyond one per byte of it (a document without aliases builds
# fewer values than it has bytes).
SPARE_VALUES = 100_000
MAX_DEPTH = 100

Loader = type[yaml.SafeLoader] | type[yaml.CSafeLoader]
SAFE_LOADER: Loader = yaml.CSafeLoader if yaml.__with_libyaml__ else yaml.SafeLoader


def loader_with(constructors: dict[str, Callable[[Any, yaml.Node], Any]]) -> Loader:
    """The safe loader, knowing these tags as well."""
    made = cast(Loader, type("SafeLoaderWith", (SAFE_LOADER,), {}))
    for tag, construct in constructors.items():
        made.add_constructor(tag, construct)
    return made


class YamlRefused(yaml.YAMLError):
    """A document outside the bounds: refused before anything of it was built."""


def _children(node: yaml.Node) -> Iterator[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        yield from node.value
    elif isinstance(node, yaml.MappingNode):
        for key, value in node.value:
            yield key
            yield value


def _measure(root: yaml.Node, max_values: int, max_depth: int) -> None:
    """Refuses a document that would build more than `max_values` values, nest deeper than
    `max_depth` or contain itself; each node is measured once, however often aliased."""
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    on_path: set[int] = set()  # the nodes from the root to the one being measured
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, measured_below = stack.pop()
        key = id(node)
        if measured_below:
            on_path.discard(key)
            below = [id(child) for child in _children(node)]
            size[key] = 1 + sum(size[k] for k in below)
            depth[key] = 1 + max((depth[k] for k in below), default=0)
            if size[key] > max_values:
                raise YamlRefused(
                    f"it would build more than {max_values} values (aliases repeating aliases?)"
                )
            if depth[key] > max_depth:
                raise YamlRefused(f"it nests deeper than {max_depth} levels")
            continue
        if key in size:
            continue
        if key in on_path:
            raise YamlRefused("it contains itself (an alias inside its own anchor)")
        on_path.add(key)
        stack.append((node, True))
        stack.extend((child, False) for child in _children(node) if id(child) not in size)


def load_yaml(
    text: str | bytes,
    loader: Loader = SAFE_LOADER,
    max_depth: int = MAX_DEPTH,
) -> Any:
    """The document in `text`, built by `loader` (a safe loader or a subclass of one);
    yaml.YAMLError if it is not YAML, YamlRefused if it is outside the bounds."""
    reader = loader(text)
    try:
        try:
            root = reader.get_single_node()
        except RecursionError:
            raise YamlRefused(f"it nests deeper than {max_depth} levels") from None
        if root is None:
            return None
        _measure(root, len(text) + SPARE_VALUES, max_depth)
        return reader.construct_document(root)
    finally:
        reader.dispose()
