"""Blockly's own Python generator is the oracle of the standard blocks. Each workspace of the
corpus (tests/support/blockly_corpus.py) is loaded into Blockly (the UI's `blockly` package,
under node, all in one process); the Python of Blockly's `pythonGenerator` runs as plain
Python, and the workspace as Blockly saved it (what the editor sends) goes through our
generator and runs in our sandbox, as a program does. Both must print the same: equal texts,
and equal values of the same types (an integer is not a float), floats within rounding where
the two compute them differently (trigonometry, means)."""

from __future__ import annotations

import ast
import asyncio
import itertools
import json
import math
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from openpendant.blockly_blocks.catalog import definition, toolbox_blocks
from openpendant.blockly_blocks.generate import generate
from openpendant.blockly_blocks.workspace import WorkspaceError
from openpendant.sandbox.guards import SandboxError
from openpendant.sandbox.library.blocks import math_is
from openpendant.sandbox.supervisor import ProgramRun, RunLimits, RunState
from tests.support.blockly_corpus import CORPUS, Workspace
from tests.unit.test_blockly_generator import STANDARD_FIELDS
from tests.unit.test_sandbox_attacks import RecordingHost

ROOT = Path(__file__).resolve().parents[2]
UI = ROOT / "webui" / "frontend"  # `make setup` runs `npm ci` here
BLOCKLY_PYTHON = ROOT / "tests" / "support" / "blockly_python.cjs"
SANDBOX_RUNS_AT_ONCE = 2
HANG_GUARD = 120.0  # s: a process that never ends fails the test instead of hanging it


@dataclass(frozen=True)
class Outcome:
    lines: list[str]
    error: str | None = None
    python: str = ""


def blockly_python(workspaces: list[Workspace]) -> list[dict[str, Any]]:
    """Blockly's code and saved workspace for each, from one node process."""
    node = shutil.which("node")
    if node is None or not (UI / "node_modules" / "blockly").is_dir():
        pytest.fail("node and the UI's node_modules are needed (make setup installs them)")
    done = subprocess.run(
        [node, str(BLOCKLY_PYTHON), str(UI)],
        input=json.dumps(workspaces),
        capture_output=True,
        text=True,
        timeout=HANG_GUARD,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    results: list[dict[str, Any]] = json.loads(done.stdout)
    return results


# Each program in a fresh namespace, its printed lines captured; one process for them all.
PLAIN_PYTHON = """
import contextlib, io, json, sys
results = []
for source in json.load(sys.stdin):
    out = io.StringIO()
    error = None
    try:
        with contextlib.redirect_stdout(out):
            exec(compile(source, "<blockly>", "exec"), {"__name__": "__main__"})
    except Exception as exc:
        error = f"{type(exc).__name__}: {exc}"
    results.append({"lines": out.getvalue().splitlines(), "error": error})
json.dump(results, sys.__stdout__)
"""


def run_plain(sources: list[str]) -> list[Outcome]:
    done = subprocess.run(
        [sys.executable, "-I", "-c", PLAIN_PYTHON],
        input=json.dumps(sources),
        capture_output=True,
        text=True,
        timeout=HANG_GUARD,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return [
        Outcome(r["lines"], r["error"], source)
        for r, source in zip(json.loads(done.stdout), sources, strict=True)
    ]


async def run_ours(saved: Workspace, limit: asyncio.Semaphore) -> Outcome:
    try:
        generated = generate(saved)
    except WorkspaceError as exc:
        return Outcome([], f"refused: {exc.message}")
    if generated.problems:
        found = "; ".join(p.message for p in generated.problems)
        return Outcome([], f"refused: {found}", generated.python)
    async with limit:
        run = ProgramRun(generated.python, RecordingHost(), limits=RunLimits(wall_seconds=60))
        await run.start()
        await run.wait(HANG_GUARD)
        await run.close()
    # A printed line may hold line breaks; split as the plain run's captured text is.
    printed = "".join(o.text + "\n" for o in run.output if o.stream == "out").splitlines()
    if run.state is not RunState.finished:
        error = run.error.message if run.error is not None else "did not finish"
        return Outcome(printed, f"{run.state.value}: {error}", generated.python)
    return Outcome(printed, None, generated.python)


@pytest.fixture(scope="module")
def outcomes() -> dict[str, tuple[Outcome, Outcome]]:
    names = list(CORPUS)
    blockly = blockly_python([CORPUS[n] for n in names])
    refused = {n: r["error"] for n, r in zip(names, blockly, strict=True) if "error" in r}
    assert not refused, f"Blockly refused workspaces of the corpus: {refused}"
    theirs = run_plain([r["python"] for r in blockly])

    async def all_ours() -> list[Outcome]:
        limit = asyncio.Semaphore(SANDBOX_RUNS_AT_ONCE)
        return await asyncio.gather(*[run_ours(r["saved"], limit) for r in blockly])

    ours = asyncio.run(all_ours())
    return {n: (t, o) for n, t, o in zip(names, theirs, ours, strict=True)}


def value(line: str) -> Any:
    try:
        return ast.literal_eval(line)
    except (ValueError, SyntaxError, MemoryError, RecursionError):
        return line  # plain text


def same(a: Any, b: Any) -> bool:
    """Equal, of the same types; floats within rounding."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float):
        return a == b or math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return bool(a == b)


def blocks_in(workspace: Workspace) -> list[dict[str, Any]]:
    found, pending = [], list(workspace["blocks"]["blocks"])
    while pending:
        block = pending.pop()
        found.append(block)
        pending += [c["block"] for c in block.get("inputs", {}).values()]
        if "next" in block:
            pending.append(block["next"]["block"])
    return found


# Dropdowns whose options are values rather than modes.
NOT_MODES = {"math_number", "text"}
# Dropdowns whose options count together (each position in each mode).
TOGETHER = {
    "lists_getIndex": ("MODE", "WHERE"),
    "lists_setIndex": ("MODE", "WHERE"),
    "lists_getSublist": ("WHERE1", "WHERE2"),
    "text_getSubstring": ("WHERE1", "WHERE2"),
    "lists_sort": ("TYPE", "DIRECTION"),
}


def test_the_corpus_has_every_mode_of_every_standard_block_of_the_toolbox() -> None:
    assert len(CORPUS) >= 60
    used: dict[str, set[tuple[Any, ...]]] = {}
    for workspace in CORPUS.values():
        for block in blocks_in(workspace):
            fields = block.get("fields", {})
            seen = used.setdefault(block["type"], set())
            names = TOGETHER.get(block["type"])
            if names is not None:
                seen.add(tuple(fields[n] for n in names))
            seen |= {(n, v) for n, v in fields.items() if not isinstance(v, dict)}
    standard = {e["type"] for e in toolbox_blocks() if definition(e["type"]) is None}
    functions = {"procedures_defreturn", "procedures_defnoreturn", "procedures_ifreturn"}
    calls = {"procedures_callreturn", "procedures_callnoreturn", "variables_get"}
    missing = [t for t in sorted(standard | functions | calls) if t not in used]
    for kind, options in STANDARD_FIELDS.items():
        if kind in NOT_MODES:
            continue
        names = TOGETHER.get(kind)
        if names is not None:
            every = itertools.product(*(options[n] for n in names))
            missing += [f"{kind} {c}" for c in every if c not in used.get(kind, set())]
        for name, values in options.items():
            missing += [
                f"{kind} {name}={v}" for v in values if (name, v) not in used.get(kind, set())
            ]
    assert missing == []


@pytest.mark.parametrize("name", list(CORPUS))
def test_a_standard_block_does_what_blocklys_python_does(
    name: str, outcomes: dict[str, tuple[Outcome, Outcome]]
) -> None:
    theirs, ours = outcomes[name]
    if theirs.error is not None or not theirs.lines:
        pytest.fail(f"Blockly's program printed {theirs.lines}, {theirs.error}\n{theirs.python}")
    if ours.error is not None:
        pytest.fail(f"ours: {ours.error}\n{ours.python}")
    equal = len(ours.lines) == len(theirs.lines) and all(
        same(value(a), value(b)) for a, b in zip(ours.lines, theirs.lines, strict=True)
    )
    if not equal:
        pytest.fail(
            f"ours printed {ours.lines}, Blockly's {theirs.lines}\n"
            f"--- ours:\n{ours.python}\n--- Blockly's:\n{theirs.python}"
        )


def test_the_prime_test_is_right_where_blocklys_trial_division_takes_too_long() -> None:
    """Below 10**12 the corpus compares with Blockly's code; beyond, with known numbers."""
    sieve = [True] * 5000
    sieve[0] = sieve[1] = False
    for n in range(2, 71):
        sieve[n * n :: n] = [False] * len(sieve[n * n :: n])
    assert [math_is("PRIME", n) for n in range(5000)] == sieve
    assert math_is("PRIME", 2**61 - 1) and math_is("PRIME", 2**521 - 1)  # Mersenne primes
    # Composite, yet a strong probable prime to every base up to 23.
    assert not math_is("PRIME", 3_825_123_056_546_413_051)
    assert not math_is("PRIME", (2**61 - 1) * (2**31 - 1))
    assert not math_is("PRIME", 2**5000)
    with pytest.raises(SandboxError, match="too large"):
        math_is("PRIME", 2**1279 - 1)
