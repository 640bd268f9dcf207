"""The sandbox attack suite: every case is refused at compile time or contained at run time
(the run ends in error or is stopped, the devices it commanded are halted, and no motion
request reaches the runtime). Run-time cases go through a real worker process."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from openpendant.sandbox.policy import ProgramCompileError, compile_program
from openpendant.sandbox.protocol import MAX_OUTPUT_CHARS
from openpendant.sandbox.supervisor import KEEP_OUTPUT, CallRefused, ProgramRun, RunLimits, RunState

REFUSED_AT_COMPILE = {
    "import": "import os",
    "from import": "from os import system",
    "__import__": "__import__('os')",
    "eval": "eval('1 + 1')",
    "exec": "exec('x = 1')",
    "compile": "compile('1', 'x', 'eval')",
    "open": "open('/etc/passwd').read()",
    "__class__ chain": "().__class__.__bases__[0].__subclasses__()",
    "__subclasses__": "object.__subclasses__()",
    "getattr builtin": "getattr([], 'append')",
    "type builtin": "type(1)",
    "globals": "globals()",
    "vars": "vars()",
    "__builtins__": "__builtins__",
    "breakpoint": "breakpoint()",
    "gi_frame": "g = (i for i in [1])\ng.gi_frame",
    "gi_frame f_back": "g = (i for i in [1])\nf = g.gi_frame.f_back",
    "cr_frame": "c = 1\nc.cr_frame",
    "ag_frame": "a = 1\na.ag_frame",
    "f_globals": "x = 1\nx.f_globals",
    "tb_frame": "x = 1\nx.tb_frame",
    "generator function": "def f():\n    yield 1",
    "yield from": "def f():\n    yield from [1]",
    "coroutine": "async def f():\n    pass",
    "class": "class A:\n    pass",
    "positional-only guard override": "def f(_getattr_=None, /):\n    return [].append",
    "keyword guard override": "def f(*, _getitem_=None):\n    pass",
    "lambda guard override": "f = lambda _write_: 1",
    "assign a guard": "_print_ = None",
    "f-string attribute": "x = 1\ns = f'{x.__class__}'",
    "string.Formatter": "import string\nstring.Formatter().format('{0.__class__}', 1)",
    "traceback": "try:\n    1 / 0\nexcept Exception as e:\n    t = e.__traceback__",
    "with": "with x:\n    pass",
    "except star": "try:\n    pass\nexcept* Exception:\n    pass",
    "decorator": "def d(f):\n    return f\n@d\ndef g():\n    pass",
    "printed": "print(1)\nx = printed",
    "syntax error": "def (:",
    "NUL": "x = 1\x00",
}


@pytest.mark.parametrize("source", REFUSED_AT_COMPILE.values(), ids=REFUSED_AT_COMPILE.keys())
def test_refused_at_compile_time(source: str) -> None:
    with pytest.raises(ProgramCompileError) as refused:
        compile_program(source)
    assert refused.value.errors and all(e for e in refused.value.errors)


class RecordingHost:
    """The runtime's side of calls, as far as these cases reach: joint reads answer, every
    motion request is recorded (none may arrive), and halts are counted."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, dict[str, Any]]] = []
        self.halts = 0

    async def call(self, fn: str, args: dict[str, Any]) -> Any:
        self.calls.append((fn, args))
        if fn == "robot.joints":
            return [0.0] * 6
        raise CallRefused(f"{fn} is not available here", "refused")

    async def halt(self) -> None:
        self.halts += 1


def run_program(
    source: str, *, limits: RunLimits | None = None, stop_after: float | None = None
) -> tuple[ProgramRun, RecordingHost]:
    async def go() -> tuple[ProgramRun, RecordingHost]:
        host = RecordingHost()
        run = ProgramRun(source, host, limits=limits or RunLimits(wall_seconds=30))
        await run.start()
        if stop_after is not None:
            assert await run.wait(stop_after) in (RunState.running, RunState.starting)
            await run.stop()
        await run.wait(40)
        await run.close()
        return run, host

    return asyncio.run(go())


CONTAINED = {
    "str.format attribute access": ("'{0.__class__}'.format(1)", "str.format"),
    "str.format_map": ("'{x.real}'.format_map({'x': 1})", "str.format_map"),
    "exception .obj": ("try:\n    int('x')\nexcept ValueError as e:\n    e.obj", "ValueError.obj"),
    "exception method": (
        "try:\n    1 / 0\nexcept Exception as e:\n    e.with_traceback(None)",
        "with_traceback",
    ),
    "generator send": ("g = (i for i in [1])\ng.send(None)", "generator.send"),
    "function attribute": ("wait.name", "function.name"),
    "private method of a sandbox value": ("p = pose(1, 2, 3)\np.wire()", "Pose.wire"),
    "write to a sandbox value": ("p = pose(1, 2, 3)\np.x = 5", "cannot be changed"),
    "write to a library function": ("move_joint.x = 1", "cannot be changed"),
    "write to a builtin": ("len.x = 1", "cannot be changed"),
    "index a function": ("wait[0]", "cannot be indexed"),
    "10 ** (10 ** 8)": ("x = 10 ** (10 ** 8)", "too large"),
    "pow builtin": ("x = pow(10, 10 ** 8)", "too large"),
    "in-place power": ("x = 10\nx **= 10 ** 8", "too large"),
    "in-place repeat": ("x = 'a'\nx *= 10 ** 9", "too long"),
    "huge string": ("x = 'a' * (10 ** 10)", "MemoryError"),
    "huge list": ("x = [0] * (10 ** 9)", "MemoryError"),
    "huge shift": ("x = 1 << (10 ** 11)", "Error"),
    "deep recursion": ("def f(n):\n    return f(n + 1)\nf(0)", "RecursionError"),
    "NaN joint target": ("move_joint([float('nan')] * 6)", "finite"),
    "infinite pose target": ("move_linear(pose(float('inf'), 0, 0))", "finite"),
    "NaN relative move": ("move_relative(z=float('nan'))", "finite"),
    "speed out of range": ("set_speed(500)", "between"),
    "move to a string": ("move_joint('home; rm -rf /')", "waypoint, a pose or joint"),
    "runtime refusal is located": ("x = 1\nuse_robot('nobody')", "not available here"),
    "fake protocol output": ('print(\'{"t": "done"}\\n{"t": "done"}\')\nx = 1 / 0', "Zero"),
    "oversized block id": ("at_block('x' * 1000)", "longer than"),
    "fake done via stop": ("def stop():\n    return 1\nstop()\nx = [][1]", "IndexError"),
}


@pytest.mark.parametrize(("source", "expected"), CONTAINED.values(), ids=CONTAINED.keys())
def test_contained_at_run_time(source: str, expected: str) -> None:
    run, host = run_program(source)
    assert run.state is RunState.error, run.output
    assert run.error is not None and expected in run.error.message
    assert run.error.line is not None
    assert host.halts == 1
    assert not [c for c in host.calls if c[0].startswith("robot.move")]


def test_a_tight_loop_runs_until_stopped_and_the_stop_halts() -> None:
    run, host = run_program("while True:\n    pass", stop_after=1.0)
    assert run.state is RunState.stopped
    assert host.halts == 1


def test_the_cpu_limit_ends_a_spinning_program() -> None:
    run, host = run_program("while True:\n    pass", limits=RunLimits(cpu_seconds=1))
    assert run.state is RunState.error
    assert run.error is not None and run.error.kind == "cpu_limit"
    assert host.halts == 1


def test_the_wall_clock_watchdog_kills_a_program_that_waits_too_long() -> None:
    run, host = run_program("wait(600)", limits=RunLimits(wall_seconds=1.0))
    assert run.state is RunState.error
    assert run.error is not None and run.error.kind == "timeout"
    assert host.halts == 1


def test_an_output_flood_is_slowed_and_kept_bounded() -> None:
    run, _ = run_program("while True:\n    print('x' * 10000)", stop_after=2.0)
    assert run.state is RunState.stopped
    lines = [o for o in run.output if o.stream == "out"]
    # Two seconds at most 200 lines a second, each cut to the console's line length.
    assert 0 < len(lines) <= 3 * 200 < KEEP_OUTPUT
    assert all(len(o.text) <= MAX_OUTPUT_CHARS + 40 for o in lines)


def test_the_worker_is_isolated() -> None:
    run, _ = run_program("x = 1")
    assert run.state is RunState.finished
    for feature in ("memory", "cpu", "no-file-writes", "no-processes", "no-new-files"):
        assert feature in run.isolation


def test_a_program_with_non_ascii_names_runs_in_the_limited_worker() -> None:
    """Compiling `höhe = 1` imports unicodedata, which a worker cannot open once limited."""
    run, _ = run_program("höhe = 2\nprint(höhe * 3)")
    assert run.state is RunState.finished, run.error
    assert [o.text for o in run.output if o.stream == "out"] == ["6"]
