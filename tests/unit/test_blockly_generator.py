"""The server-side generator: every block of the toolbox (and of the Variables and Functions
categories Blockly fills in) with every option of its dropdowns generates Python that
compiles under the sandbox policy; generated programs compute what the blocks say; and
malformed workspaces are refused with a clear error."""

from __future__ import annotations

import asyncio
import copy
import itertools
import json
import sys
from typing import Any

import pytest

from openpendant.blockly_blocks.catalog import definition, toolbox_blocks
from openpendant.blockly_blocks.generate import generate, known_types
from openpendant.blockly_blocks.workspace import MAX_BLOCKS, MAX_NESTING, WorkspaceError
from openpendant.runtime.bench.harness import blocks as wb
from openpendant.sandbox.policy import compile_program
from openpendant.sandbox.supervisor import ProgramRun, RunLimits, RunState
from tests.unit.test_sandbox_attacks import RecordingHost

# Blockly's standard blocks: each dropdown with its options (the first is the default).
STANDARD_FIELDS: dict[str, dict[str, list[Any]]] = {
    "logic_compare": {"OP": ["EQ", "NEQ", "LT", "LTE", "GT", "GTE"]},
    "logic_operation": {"OP": ["AND", "OR"]},
    "logic_boolean": {"BOOL": ["TRUE", "FALSE"]},
    "controls_whileUntil": {"MODE": ["WHILE", "UNTIL"]},
    "controls_flow_statements": {"FLOW": ["BREAK", "CONTINUE"]},
    "math_number": {"NUM": [0, -2.5, 1e6]},
    "math_arithmetic": {"OP": ["ADD", "MINUS", "MULTIPLY", "DIVIDE", "POWER"]},
    "math_single": {"OP": ["ROOT", "ABS", "NEG", "LN", "LOG10", "EXP", "POW10"]},
    "math_trig": {"OP": ["SIN", "COS", "TAN", "ASIN", "ACOS", "ATAN"]},
    "math_constant": {"CONSTANT": ["PI", "E", "GOLDEN_RATIO", "SQRT2", "SQRT1_2", "INFINITY"]},
    "math_number_property": {
        "PROPERTY": ["EVEN", "ODD", "PRIME", "WHOLE", "POSITIVE", "NEGATIVE", "DIVISIBLE_BY"]
    },
    "math_round": {"OP": ["ROUND", "ROUNDUP", "ROUNDDOWN"]},
    "math_on_list": {"OP": ["SUM", "MIN", "MAX", "AVERAGE", "MEDIAN", "MODE", "STD_DEV", "RANDOM"]},
    "text": {"TEXT": ["", "it's \"quoted\"\n\\ and 'more'"]},
    "text_indexOf": {"END": ["FIRST", "LAST"]},
    "text_charAt": {"WHERE": ["FROM_START", "FROM_END", "FIRST", "LAST", "RANDOM"]},
    "text_getSubstring": {
        "WHERE1": ["FROM_START", "FROM_END", "FIRST"],
        "WHERE2": ["FROM_START", "FROM_END", "LAST"],
    },
    "text_changeCase": {"CASE": ["UPPERCASE", "LOWERCASE", "TITLECASE"]},
    "text_trim": {"MODE": ["BOTH", "LEFT", "RIGHT"]},
    "lists_indexOf": {"END": ["FIRST", "LAST"]},
    "lists_getIndex": {
        "MODE": ["GET", "GET_REMOVE", "REMOVE"],
        "WHERE": ["FROM_START", "FROM_END", "FIRST", "LAST", "RANDOM"],
    },
    "lists_setIndex": {
        "MODE": ["SET", "INSERT"],
        "WHERE": ["FROM_START", "FROM_END", "FIRST", "LAST", "RANDOM"],
    },
    "lists_getSublist": {
        "WHERE1": ["FROM_START", "FROM_END", "FIRST"],
        "WHERE2": ["FROM_START", "FROM_END", "LAST"],
    },
    "lists_split": {"MODE": ["SPLIT", "JOIN"]},
    "lists_sort": {"TYPE": ["NUMERIC", "TEXT", "IGNORE_CASE"], "DIRECTION": ["1", "-1"]},
}
VARIABLE_FIELDS = {
    "controls_for",
    "controls_forEach",
    "math_change",
    "text_append",
    "variables_get",
    "variables_set",
}
# What Blockly's Variables and Functions categories offer (they are filled at run time).
DYNAMIC_BLOCKS = [
    {"kind": "block", "type": t}
    for t in ("variables_get", "variables_set", "procedures_callnoreturn", "procedures_callreturn")
]


def field_options(block_type: str) -> dict[str, list[Any]]:
    if block_type in STANDARD_FIELDS:
        return STANDARD_FIELDS[block_type]
    found = definition(block_type)
    options: dict[str, list[Any]] = {}
    for arg in (found or {}).get("args0", []):
        if arg["type"] == "field_dropdown":
            options[arg["name"]] = [o[1] for o in arg["options"]]
        elif arg["type"] == "field_input":
            options[arg["name"]] = [arg.get("text", "x")]
    return options


ids = itertools.count(1)


def instance(entry: dict[str, Any], fields: dict[str, Any]) -> dict[str, Any]:
    """A toolbox entry as a saved block: ids everywhere, fields set, shadows kept."""
    block = copy.deepcopy(entry)
    block.pop("kind", None)
    block["id"] = f"b{next(ids)}"
    # Blockly saves every field; one the toolbox leaves unset holds its first option.
    defaults = {name: values[0] for name, values in field_options(block["type"]).items()}
    block["fields"] = {**defaults, **block.get("fields", {}), **fields}
    if block["type"] in VARIABLE_FIELDS:
        block["fields"]["VAR"] = {"id": "var1"}
    for connection in block.get("inputs", {}).values():
        for key in ("block", "shadow"):
            if key in connection:
                connection[key] = instance(connection[key], {})
    if block["type"] in ("procedures_callnoreturn", "procedures_callreturn"):
        target = "act" if block["type"] == "procedures_callnoreturn" else "compute"
        block["extraState"] = {"name": target, "params": ["item"]}
        block["inputs"] = {
            "ARG0": {"block": {"type": "math_number", "id": f"b{next(ids)}", "fields": {"NUM": 1}}}
        }
    return block


def is_value(block: dict[str, Any]) -> bool:
    found = definition(block["type"])
    if found is not None:
        return "output" in found
    statements = {
        "controls_if",
        "controls_repeat_ext",
        "controls_whileUntil",
        "controls_for",
        "controls_forEach",
        "controls_flow_statements",
        "math_change",
        "text_append",
        "text_print",
        "lists_setIndex",
        "variables_set",
        "procedures_callnoreturn",
    }
    if block["type"] == "lists_getIndex":
        return bool(block["fields"].get("MODE") != "REMOVE")
    return block["type"] not in statements


FUNCTIONS = [
    {
        "type": "procedures_defnoreturn",
        "id": "def1",
        "x": 0,
        "y": -100,
        "fields": {"NAME": "act"},
        "extraState": {"params": [{"name": "item", "id": "var2"}]},
        "inputs": {
            "STACK": {
                "block": {
                    "type": "procedures_ifreturn",
                    "id": "ifr1",
                    "inputs": {
                        "CONDITION": {
                            "block": {
                                "type": "logic_boolean",
                                "id": "c1",
                                "fields": {"BOOL": "TRUE"},
                            }
                        }
                    },
                }
            }
        },
    },
    {
        "type": "procedures_defreturn",
        "id": "def2",
        "x": 0,
        "y": -50,
        "fields": {"NAME": "compute"},
        "extraState": {"params": [{"name": "item", "id": "var2"}]},
        "inputs": {
            "RETURN": {
                "block": {"type": "variables_get", "id": "r1", "fields": {"VAR": {"id": "var2"}}}
            }
        },
    },
]


def workspace_with(block: dict[str, Any]) -> dict[str, Any]:
    top = block
    if is_value(block):
        top = {
            "type": "variables_set",
            "id": f"b{next(ids)}",
            "fields": {"VAR": {"id": "var1"}},
            "inputs": {"VALUE": {"block": block}},
        }
    if block["type"] in ("controls_flow_statements",):
        top = {
            "type": "controls_whileUntil",
            "id": f"b{next(ids)}",
            "fields": {"MODE": "WHILE"},
            "inputs": {"DO": {"block": block}},
        }
    return {
        "blocks": {"languageVersion": 0, "blocks": [*copy.deepcopy(FUNCTIONS), top]},
        "variables": [{"name": "my value", "id": "var1"}, {"name": "item", "id": "var2"}],
    }


def variants(entry: dict[str, Any]) -> list[dict[str, Any]]:
    options = field_options(entry["type"])
    out = [instance(entry, {name: values[0] for name, values in options.items()})]
    for name, values in options.items():
        for choice in values[1:]:
            chosen = {n: v[0] for n, v in options.items()}
            chosen[name] = choice
            out.append(instance(entry, chosen))
    return out


ALL_ENTRIES = [*toolbox_blocks(), *DYNAMIC_BLOCKS]


@pytest.mark.parametrize("entry", ALL_ENTRIES, ids=[e["type"] for e in ALL_ENTRIES])
def test_every_toolbox_block_generates_code_the_sandbox_compiles(entry: dict[str, Any]) -> None:
    for block in variants(entry):
        generated = generate(workspace_with(block))
        compile_program(generated.python)
        assert generated.python.count("at_block(") >= 2
        if not is_value(block):
            assert block["id"] in generated.block_lines, generated.python


def test_the_toolbox_covers_every_generator_and_the_catalog() -> None:
    in_toolbox = {e["type"] for e in ALL_ENTRIES}
    defined_elsewhere = {
        "procedures_defnoreturn",
        "procedures_defreturn",
        "procedures_ifreturn",
        "controls_repeat",
        "math_change",
    }
    assert known_types() - in_toolbox - defined_elsewhere == set()
    assert {e["type"] for e in toolbox_blocks()} <= known_types()


def run_blocks(blocks: list[dict[str, Any]], variables: list[str]) -> list[str]:
    workspace = {
        "blocks": {"blocks": blocks},
        "variables": [{"name": v, "id": v} for v in variables],
    }
    python = generate(workspace).python

    async def go() -> list[str]:
        run = ProgramRun(python, RecordingHost(), limits=RunLimits(wall_seconds=20))
        await run.start()
        state = await run.wait(25)
        await run.close()
        assert state is RunState.finished, (run.error, python)
        return [o.text for o in run.output]

    return asyncio.run(go())


def num(n: float) -> dict[str, Any]:
    return {"block": {"type": "math_number", "id": f"n{next(ids)}", "fields": {"NUM": n}}}


def var(name: str) -> dict[str, Any]:
    return {
        "block": {"type": "variables_get", "id": f"g{next(ids)}", "fields": {"VAR": {"id": name}}}
    }


def chain(*blocks: dict[str, Any]) -> dict[str, Any]:
    for a, b in itertools.pairwise(blocks):
        a["next"] = {"block": b}
    return blocks[0]


def stmt(kind: str, fields: dict[str, Any] | None = None, **inputs: Any) -> dict[str, Any]:
    return {"type": kind, "id": f"s{next(ids)}", "fields": fields or {}, "inputs": inputs}


def test_generated_programs_compute_what_the_blocks_say() -> None:
    printed = run_blocks(
        [
            chain(
                stmt("variables_set", {"VAR": {"id": "total"}}, VALUE=num(0)),
                stmt(
                    "controls_for",
                    {"VAR": {"id": "i"}},
                    FROM=num(1),
                    TO=num(10),
                    BY=num(1),
                    DO={"block": stmt("math_change", {"VAR": {"id": "total"}}, DELTA=var("i"))},
                ),
                stmt("text_print", TEXT=var("total")),
                stmt(
                    "controls_for",
                    {"VAR": {"id": "i"}},
                    FROM=num(3),
                    TO=num(1),
                    BY=num(1),
                    DO={"block": stmt("text_print", TEXT=var("i"))},
                ),
                stmt(
                    "variables_set",
                    {"VAR": {"id": "items"}},
                    VALUE={
                        "block": {
                            "type": "lists_create_with",
                            "id": "lc",
                            "extraState": {"itemCount": 3},
                            "inputs": {"ADD0": num(5), "ADD1": num(2), "ADD2": num(9)},
                        }
                    },
                ),
                stmt(
                    "text_print",
                    TEXT={
                        "block": {
                            "type": "lists_getIndex",
                            "id": "gi",
                            "fields": {"MODE": "GET", "WHERE": "FROM_END"},
                            "inputs": {"VALUE": var("items"), "AT": num(1)},
                        }
                    },
                ),
                stmt(
                    "text_print",
                    TEXT={
                        "block": {
                            "type": "math_on_list",
                            "id": "ml",
                            "fields": {"OP": "MEDIAN"},
                            "inputs": {"LIST": var("items")},
                        }
                    },
                ),
                stmt(
                    "controls_if",
                    IF0={
                        "block": {
                            "type": "logic_compare",
                            "id": "lc2",
                            "fields": {"OP": "GT"},
                            "inputs": {"A": var("total"), "B": num(50)},
                        }
                    },
                    DO0={
                        "block": stmt(
                            "text_print",
                            TEXT={"block": {"type": "text", "id": "t1", "fields": {"TEXT": "big"}}},
                        )
                    },
                ),
                stmt(
                    "text_print",
                    TEXT={
                        "block": {
                            "type": "math_trig",
                            "id": "tr",
                            "fields": {"OP": "SIN"},
                            "inputs": {"NUM": num(90)},
                        }
                    },
                ),
            )
        ],
        ["total", "i", "items"],
    )
    assert printed == ["55", "3", "2", "1", "9", "5", "big", "1.0"]


def test_functions_with_parameters_and_globals() -> None:
    define = {
        "type": "procedures_defreturn",
        "id": "f",
        "x": 0,
        "y": 0,
        "fields": {"NAME": "double it"},
        "extraState": {"params": [{"name": "x", "id": "x"}]},
        "inputs": {
            "STACK": {"block": stmt("math_change", {"VAR": {"id": "calls"}}, DELTA=num(1))},
            "RETURN": {
                "block": {
                    "type": "math_arithmetic",
                    "id": "m",
                    "fields": {"OP": "MULTIPLY"},
                    "inputs": {"A": var("x"), "B": num(2)},
                }
            },
        },
    }
    call = {
        "type": "procedures_callreturn",
        "id": "c",
        "extraState": {"name": "double it"},
        "inputs": {"ARG0": num(21)},
    }
    main = chain(
        stmt("variables_set", {"VAR": {"id": "calls"}}, VALUE=num(0)),
        stmt("text_print", TEXT={"block": call}),
        stmt("text_print", TEXT=var("calls")),
    )
    main["y"] = 100
    assert run_blocks([define, main], ["x", "calls"]) == ["42", "1"]


def dumps(data: Any) -> str:
    """JSON of a long stack (each statement nests one level deeper)."""
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(50_000)
    try:
        return json.dumps(data)
    finally:
        sys.setrecursionlimit(limit)


def ws(*blocks: dict[str, Any], variables: list[dict[str, str]] | None = None) -> dict[str, Any]:
    return {"blocks": {"blocks": list(blocks)}, "variables": variables or []}


def nested(depth: int) -> dict[str, Any]:
    block: dict[str, Any] = {"type": "logic_negate", "id": "deep0"}
    for i in range(1, depth):
        block = {"type": "logic_negate", "id": f"deep{i}", "inputs": {"BOOL": {"block": block}}}
    return {"type": "controls_if", "id": "top", "inputs": {"IF0": {"block": block}}}


MALFORMED: dict[str, tuple[Any, str]] = {
    "not JSON": ("{blocks: ", "not JSON"),
    "not an object": ("[1, 2]", "JSON object"),
    "NaN": (
        '{"blocks": {"blocks": [{"type": "math_number", "id": "a", "fields": {"NUM": NaN}}]}}',
        "NaN",
    ),
    "unknown block type": (ws({"type": "os_system", "id": "a"}), "unknown block type"),
    "block without id": (ws({"type": "text_print"}), "id"),
    "block id used twice": (
        ws(
            chain(stmt("text_print"), {"type": "text_print", "id": "dup"}),
            {"type": "text_print", "id": "dup", "y": 50},
        ),
        "used twice",
    ),
    "missing field": (ws({"type": "logic_boolean", "id": "a"}), "lacks its BOOL"),
    "bad dropdown value": (
        ws(
            stmt(
                "variables_set",
                {"VAR": {"id": "v"}},
                VALUE={
                    "block": {"type": "math_arithmetic", "id": "m", "fields": {"OP": "__import__"}}
                },
            ),
            variables=[{"name": "v", "id": "v"}],
        ),
        "not one of",
    ),
    "unknown variable": (ws(stmt("variables_set", {"VAR": {"id": "nope"}})), "variable"),
    "value used as statement": (
        ws(
            {
                "type": "math_number",
                "id": "a",
                "fields": {"NUM": 1},
                "next": {"block": {"type": "text_print", "id": "b"}},
            }
        ),
        "cannot be used as a statement",
    ),
    "statement used as value": (
        ws(stmt("text_print", TEXT={"block": stmt("text_print")})),
        "cannot be used as a value",
    ),
    "call of an undefined function": (
        ws({"type": "procedures_callnoreturn", "id": "c", "extraState": {"name": "ghost"}}),
        "not defined",
    ),
    "infinite number field": (
        ws(
            stmt(
                "text_print",
                TEXT={"block": {"type": "math_number", "id": "n", "fields": {"NUM": 1e400}}},
            )
        ),
        "Infinity",
    ),
    "deeply nested blocks": (ws(nested(MAX_NESTING + 5)), "nested more than"),
    "deeply nested JSON": ('{"blocks": ' + "[" * 100_000 + "]" * 100_000 + "}", "nested too"),
    "too many blocks": (
        ws(chain(*[stmt("text_print") for _ in range(MAX_BLOCKS + 1)])),
        "more than",
    ),
    "enormous JSON": (
        '{"blocks": {"blocks": []}, "pad": "' + "x" * (5 * 1024 * 1024) + '"}',
        "larger than",
    ),
    "item count out of range": (
        ws(
            stmt(
                "text_print",
                TEXT={
                    "block": {"type": "text_join", "id": "j", "extraState": {"itemCount": 10**9}}
                },
            )
        ),
        "malformed itemCount",
    ),
    "inputs not an object": (ws({"type": "text_print", "id": "a", "inputs": [1]}), "malformed"),
    "if-return outside a function": (ws(stmt("procedures_ifreturn")), "inside a function"),
}


@pytest.mark.parametrize(("workspace", "expected"), MALFORMED.values(), ids=MALFORMED.keys())
def test_malformed_workspaces_are_refused_clearly(workspace: Any, expected: str) -> None:
    data = workspace if isinstance(workspace, str) else dumps(workspace)
    with pytest.raises(WorkspaceError) as refused:
        generate(data)
    assert expected in refused.value.message


def test_a_long_stack_is_read_without_recursion() -> None:
    blocks = [
        stmt(
            "text_print",
            TEXT={"block": {"type": "text", "id": f"t{i}", "fields": {"TEXT": str(i)}}},
        )
        for i in range(2000)
    ]
    generated = generate(dumps(ws(chain(*blocks))))
    compile_program(generated.python)
    assert generated.blocks == 4000


def test_empty_inputs_and_loose_blocks_are_problems_that_name_their_block() -> None:
    """An empty `if` condition would silently be `if False:`, and a stack lying apart would
    run after the program unseen: both are reported at their blocks."""
    empty_if = wb.block("controls_if", None, DO0=wb.block("text_print", None, TEXT=wb.text("x")))
    no_target = wb.block("robot_move_joint")
    main = wb.stack(empty_if, no_target)
    apart = wb.block("text_print", None, TEXT=wb.text("stray"))
    apart["y"] = 500
    loose_value = wb.block("math_number", {"NUM": 3})
    loose_value["y"] = 600
    generated = generate(wb.workspace(main, apart, loose_value))
    found = {p.block: p.message for p in generated.problems}
    assert found[empty_if["id"]] == "the 'if' block: the condition is empty"
    assert found[no_target["id"]] == "the 'move joint' block: the target is empty"
    assert "not part of the program" in found[apart["id"]]
    assert "not part of the program" in found[loose_value["id"]]
    assert len(found) == 4
    # The code is still generated (it is saved, and the preview shows it), but not run.
    assert "if False:" in generated.python


def test_optional_inputs_and_a_complete_program_have_no_problems() -> None:
    items = wb.block("lists_create_with", None, ADD0=wb.number(1))
    items["extraState"] = {"itemCount": 3}  # two empty slots: empty items, as in Blockly
    ws = wb.workspace(
        wb.block("text_print", None, TEXT=wb.block("lists_length", None, VALUE=items))
    )
    assert generate(ws).problems == []
