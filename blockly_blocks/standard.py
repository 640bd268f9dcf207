"""Generators for Blockly's standard blocks: logic, loops, math, text, lists, variables and
functions, with Blockly's meaning (1-based positions, degrees for trigonometry)."""

from __future__ import annotations

from openpendant.blockly_blocks.generator import (
    DUAL,
    Generator,
    indent,
    py_string,
    statement,
    value,
)
from openpendant.blockly_blocks.workspace import Block, WorkspaceError
from openpendant.runtime.kit.words import words

MAX_ITEMS = 500

# Logic ------------------------------------------------------------------------------------


@statement("controls_if")
def controls_if(block: Block, g: Generator) -> list[str]:
    count = _count(block, "elseIfCount", 0)
    lines = [f"if {g.value(block, 'IF0', 'False')}:", *g.body(block, "DO0")]
    for i in range(1, count + 1):
        lines += [f"elif {g.value(block, f'IF{i}', 'False')}:", *g.body(block, f"DO{i}")]
    if block.extra.get("hasElse") or "ELSE" in block.inputs:
        lines += ["else:", *g.body(block, "ELSE")]
    return lines


COMPARE = {"EQ": "==", "NEQ": "!=", "LT": "<", "LTE": "<=", "GT": ">", "GTE": ">="}


@value("logic_compare")
def logic_compare(block: Block, g: Generator) -> str:
    op = COMPARE[g.option(block, "OP", COMPARE)]
    return f"({g.value(block, 'A')} {op} {g.value(block, 'B')})"


@value("logic_operation")
def logic_operation(block: Block, g: Generator) -> str:
    op = g.option(block, "OP", ("AND", "OR")).lower()
    return f"({g.value(block, 'A', 'False')} {op} {g.value(block, 'B', 'False')})"


@value("logic_negate")
def logic_negate(block: Block, g: Generator) -> str:
    return f"(not {g.value(block, 'BOOL', 'True')})"


@value("logic_boolean")
def logic_boolean(block: Block, g: Generator) -> str:
    return "True" if g.option(block, "BOOL", ("TRUE", "FALSE")) == "TRUE" else "False"


@value("logic_null")
def logic_null(block: Block, g: Generator) -> str:
    return "None"


@value("logic_ternary")
def logic_ternary(block: Block, g: Generator) -> str:
    return (
        f"({g.value(block, 'THEN')} if {g.value(block, 'IF', 'False')} "
        f"else {g.value(block, 'ELSE')})"
    )


# Loops ------------------------------------------------------------------------------------


def _loop_body(block: Block, g: Generator, name: str = "DO") -> list[str]:
    """A loop's body starts with the loop's own marker, so a tight loop can be paused."""
    return indent([f"at_block({block.id!r})", *g.stack(block.inputs.get(name))])


@statement("controls_repeat_ext", "controls_repeat")
def controls_repeat(block: Block, g: Generator) -> list[str]:
    if block.type == "controls_repeat":
        times = str(g.number_field(block, "TIMES"))
    else:
        times = g.value(block, "TIMES", "0")
    counter = g.names.fresh("count")
    return [f"for {counter} in range(int({times})):", *_loop_body(block, g)]


@statement("controls_whileUntil")
def controls_while_until(block: Block, g: Generator) -> list[str]:
    condition = g.value(block, "BOOL", "False")
    if g.option(block, "MODE", ("WHILE", "UNTIL")) == "UNTIL":
        condition = f"not {condition}"
    return [f"while {condition}:", *_loop_body(block, g)]


@statement("controls_for")
def controls_for(block: Block, g: Generator) -> list[str]:
    var = g.variable(block)
    start, stop = g.value(block, "FROM", "0"), g.value(block, "TO", "0")
    step = g.value(block, "BY", "1")
    return [f"for {var} in count_range({start}, {stop}, {step}):", *_loop_body(block, g)]


@statement("controls_forEach")
def controls_for_each(block: Block, g: Generator) -> list[str]:
    var = g.variable(block)
    return [f"for {var} in {g.value(block, 'LIST', '[]')}:", *_loop_body(block, g)]


@statement("controls_flow_statements")
def controls_flow(block: Block, g: Generator) -> list[str]:
    return [g.option(block, "FLOW", ("BREAK", "CONTINUE")).lower()]


# Math -------------------------------------------------------------------------------------


@value("math_number")
def math_number(block: Block, g: Generator) -> str:
    number = g.number_field(block, "NUM")
    return repr(number) if number >= 0 else f"({number!r})"


ARITHMETIC = {"ADD": "+", "MINUS": "-", "MULTIPLY": "*", "DIVIDE": "/", "POWER": "**"}


@value("math_arithmetic")
def math_arithmetic(block: Block, g: Generator) -> str:
    op = ARITHMETIC[g.option(block, "OP", ARITHMETIC)]
    return f"({g.value(block, 'A', '0')} {op} {g.value(block, 'B', '0')})"


@value("math_single")
def math_single(block: Block, g: Generator) -> str:
    op = g.option(block, "OP", ("ROOT", "ABS", "NEG", "LN", "LOG10", "EXP", "POW10"))
    return f"math_single({op!r}, {g.value(block, 'NUM', '0')})"


@value("math_trig")
def math_trig(block: Block, g: Generator) -> str:
    op = g.option(block, "OP", ("SIN", "COS", "TAN", "ASIN", "ACOS", "ATAN"))
    return f"math_trig({op!r}, {g.value(block, 'NUM', '0')})"


@value("math_constant")
def math_constant(block: Block, g: Generator) -> str:
    name = g.option(block, "CONSTANT", ("PI", "E", "GOLDEN_RATIO", "SQRT2", "SQRT1_2", "INFINITY"))
    return f"math_constant({name!r})"


@value("math_number_property")
def math_number_property(block: Block, g: Generator) -> str:
    prop = g.option(
        block,
        "PROPERTY",
        ("EVEN", "ODD", "PRIME", "WHOLE", "POSITIVE", "NEGATIVE", "DIVISIBLE_BY"),
    )
    number = g.value(block, "NUMBER_TO_CHECK", "0")
    if prop != "DIVISIBLE_BY":  # Blockly's block has a divisor input only then
        return f"math_is({prop!r}, {number})"
    return f"math_is({prop!r}, {number}, {g.value(block, 'DIVISOR', 'None')})"


@value("math_round")
def math_round(block: Block, g: Generator) -> str:
    op = g.option(block, "OP", ("ROUND", "ROUNDUP", "ROUNDDOWN"))
    return f"math_round({op!r}, {g.value(block, 'NUM', '0')})"


@value("math_on_list")
def math_on_list(block: Block, g: Generator) -> str:
    ops = ("SUM", "MIN", "MAX", "AVERAGE", "MEDIAN", "MODE", "STD_DEV", "RANDOM")
    op = g.option(block, "OP", ops)
    return f"math_on_list({op!r}, {g.value(block, 'LIST', '[]')})"


@value("math_modulo")
def math_modulo(block: Block, g: Generator) -> str:
    return f"({g.value(block, 'DIVIDEND', '0')} % {g.value(block, 'DIVISOR', '0')})"


@value("math_constrain")
def math_constrain(block: Block, g: Generator) -> str:
    args = ", ".join(g.value(block, n, d) for n, d in (("VALUE", "0"), ("LOW", "0"), ("HIGH", "0")))
    return f"math_constrain({args})"


@value("math_random_int")
def math_random_int(block: Block, g: Generator) -> str:
    return f"random_int({g.value(block, 'FROM', '0')}, {g.value(block, 'TO', '0')})"


@value("math_random_float")
def math_random_float(block: Block, g: Generator) -> str:
    return "random_fraction()"


@value("math_atan2")
def math_atan2(block: Block, g: Generator) -> str:
    return f"math_atan2({g.value(block, 'X', '0')}, {g.value(block, 'Y', '0')})"


@statement("math_change")
def math_change(block: Block, g: Generator) -> list[str]:
    var = g.variable(block)
    delta = g.value(block, "DELTA", "0")
    return [f"{var} = ({var} if isinstance({var}, (int, float)) else 0) + {delta}"]


# Text -------------------------------------------------------------------------------------


@value("text")
def text(block: Block, g: Generator) -> str:
    return py_string(g.text_field(block, "TEXT"))


@value("text_join")
def text_join(block: Block, g: Generator) -> str:
    count = _count(block, "itemCount", 2)
    parts = [g.value(block, f"ADD{i}", "''", optional=True) for i in range(count)]
    return f"text_join({', '.join(parts)})"


@statement("text_append")
def text_append(block: Block, g: Generator) -> list[str]:
    var = g.variable(block)
    return [f"{var} = str({var}) + str({g.value(block, 'TEXT', repr(''))})"]


@value("text_length")
def text_length(block: Block, g: Generator) -> str:
    return f"len({g.value(block, 'VALUE', repr(''))})"


@value("text_isEmpty")
def text_is_empty(block: Block, g: Generator) -> str:
    return f"(len({g.value(block, 'VALUE', repr(''))}) == 0)"


@value("text_indexOf", "lists_indexOf")
def index_of(block: Block, g: Generator) -> str:
    helper = "find_first" if g.option(block, "END", ("FIRST", "LAST")) == "FIRST" else "find_last"
    default = "''" if block.type == "text_indexOf" else "[]"
    return f"{helper}({g.value(block, 'VALUE', default)}, {g.value(block, 'FIND', repr(''))})"


WHERE = ("FROM_START", "FROM_END", "FIRST", "LAST", "RANDOM")
NUMBERED = ("FROM_START", "FROM_END")


def _position(block: Block, g: Generator, where: str, name: str = "AT") -> str:
    """The number of a position; Blockly's block removes its input for FIRST, LAST and RANDOM
    (a stale one left in the JSON is not part of the block)."""
    return g.value(block, name, "1") if where in NUMBERED else "None"


@value("text_charAt")
def text_char_at(block: Block, g: Generator) -> str:
    where = g.option(block, "WHERE", WHERE)
    text_value = g.value(block, "VALUE", repr(""))
    return f"item_get({text_value}, 'GET', {where!r}, {_position(block, g, where)})"


@value("text_getSubstring", "lists_getSublist")
def sub_sequence(block: Block, g: Generator) -> str:
    source = "STRING" if block.type == "text_getSubstring" else "LIST"
    where1 = g.option(block, "WHERE1", ("FROM_START", "FROM_END", "FIRST"))
    where2 = g.option(block, "WHERE2", ("FROM_START", "FROM_END", "LAST"))
    at1 = _position(block, g, where1, "AT1")
    at2 = _position(block, g, where2, "AT2")
    return f"sub_sequence({g.value(block, source, '[]')}, {where1!r}, {at1}, {where2!r}, {at2})"


@value("text_changeCase")
def text_change_case(block: Block, g: Generator) -> str:
    case = g.option(block, "CASE", ("UPPERCASE", "LOWERCASE", "TITLECASE"))
    text_value = g.value(block, "TEXT", repr(""))
    if case == "TITLECASE":
        return f"text_title({text_value})"
    return f"str({text_value}).{case[:-4].lower()}()"


@value("text_trim")
def text_trim(block: Block, g: Generator) -> str:
    mode = g.option(block, "MODE", ("BOTH", "LEFT", "RIGHT"))
    method = {"BOTH": "strip", "LEFT": "lstrip", "RIGHT": "rstrip"}[mode]
    return f"str({g.value(block, 'TEXT', repr(''))}).{method}()"


@statement("text_print")
def text_print(block: Block, g: Generator) -> list[str]:
    return [f"print({g.value(block, 'TEXT', repr(''))})"]


@value("text_count")
def text_count(block: Block, g: Generator) -> str:
    return f"str({g.value(block, 'TEXT', repr(''))}).count({g.value(block, 'SUB', repr(''))})"


@value("text_replace")
def text_replace(block: Block, g: Generator) -> str:
    return (
        f"str({g.value(block, 'TEXT', repr(''))}).replace("
        f"{g.value(block, 'FROM', repr(''))}, {g.value(block, 'TO', repr(''))})"
    )


@value("text_reverse")
def text_reverse(block: Block, g: Generator) -> str:
    return f"text_join(*reversed(str({g.value(block, 'TEXT', repr(''))})))"


# Lists ------------------------------------------------------------------------------------


@value("lists_create_empty")
def lists_create_empty(block: Block, g: Generator) -> str:
    return "[]"


@value("lists_create_with")
def lists_create_with(block: Block, g: Generator) -> str:
    count = _count(block, "itemCount", 3)
    return "[" + ", ".join(g.value(block, f"ADD{i}", optional=True) for i in range(count)) + "]"


@value("lists_repeat")
def lists_repeat(block: Block, g: Generator) -> str:
    return f"([{g.value(block, 'ITEM')}] * int({g.value(block, 'NUM', '0')}))"


@value("lists_length")
def lists_length(block: Block, g: Generator) -> str:
    return f"len({g.value(block, 'VALUE', '[]')})"


@value("lists_isEmpty")
def lists_is_empty(block: Block, g: Generator) -> str:
    return f"(len({g.value(block, 'VALUE', '[]')}) == 0)"


def _get_index_call(block: Block, g: Generator) -> str:
    mode = g.option(block, "MODE", ("GET", "GET_REMOVE", "REMOVE"))
    where = g.option(block, "WHERE", WHERE)
    return (
        f"item_get({g.value(block, 'VALUE', '[]')}, {mode!r}, {where!r}, "
        f"{_position(block, g, where)})"
    )


def _get_index_is_statement(block: Block) -> bool:
    return block.fields.get("MODE") == "REMOVE" or bool(block.extra.get("isStatement"))


DUAL["lists_getIndex"] = _get_index_is_statement
value("lists_getIndex")(_get_index_call)


@statement("lists_getIndex")
def lists_get_index_statement(block: Block, g: Generator) -> list[str]:
    return [_get_index_call(block, g)]


@statement("lists_setIndex")
def lists_set_index(block: Block, g: Generator) -> list[str]:
    mode = g.option(block, "MODE", ("SET", "INSERT"))
    where = g.option(block, "WHERE", WHERE)
    return [
        f"item_set({g.value(block, 'LIST', '[]')}, {mode!r}, {where!r}, "
        f"{_position(block, g, where)}, {g.value(block, 'TO')})"
    ]


@value("lists_split")
def lists_split(block: Block, g: Generator) -> str:
    mode = g.option(block, "MODE", ("SPLIT", "JOIN"))
    delimiter = g.value(block, "DELIM", repr(","))
    if mode == "SPLIT":
        return f"str({g.value(block, 'INPUT', repr(''))}).split({delimiter})"
    return f"str({delimiter}).join([str(x) for x in {g.value(block, 'INPUT', '[]')}])"


@value("lists_sort")
def lists_sort(block: Block, g: Generator) -> str:
    kind = g.option(block, "TYPE", ("NUMERIC", "TEXT", "IGNORE_CASE"))
    direction = g.option(block, "DIRECTION", ("1", "-1"))
    return f"sort_list({g.value(block, 'LIST', '[]')}, {kind!r}, {direction})"


@value("lists_reverse")
def lists_reverse(block: Block, g: Generator) -> str:
    return f"list(reversed({g.value(block, 'LIST', '[]')}))"


# Variables --------------------------------------------------------------------------------


@value("variables_get")
def variables_get(block: Block, g: Generator) -> str:
    return g.variable(block)


@statement("variables_set")
def variables_set(block: Block, g: Generator) -> list[str]:
    return [f"{g.variable(block)} = {g.value(block, 'VALUE')}"]


# Functions --------------------------------------------------------------------------------


def _params(block: Block) -> list[dict[str, str]]:
    params = block.extra.get("params", [])
    if not isinstance(params, list) or len(params) > 32:
        raise WorkspaceError("a function's parameters are malformed", block.id)
    for p in params:
        if not isinstance(p, dict) or not isinstance(p.get("name"), str):
            raise WorkspaceError("a function's parameters are malformed", block.id)
    return params


@statement("procedures_defnoreturn", "procedures_defreturn")
def procedures_def(block: Block, g: Generator) -> list[str]:
    name = g.names.get("procedure", g.text_field(block, "NAME"))
    by_name = {n: i for i, n in g.workspace.variables.items()}
    params = []
    for p in _params(block):
        var_id = p.get("id") or by_name.get(p["name"])
        if var_id is None or var_id not in g.workspace.variables:
            raise WorkspaceError(f"parameter {p['name']!r} is not a variable", block.id)
        params.append(g.var_name(var_id))
    others = [g.var_name(v) for v in g.workspace.variables]
    globals_ = [v for v in others if v not in params]
    body = [f"global {', '.join(globals_)}"] if globals_ else []
    body += g.stack(block.inputs.get("STACK"))
    if block.type == "procedures_defreturn":
        body.append(f"return {g.value(block, 'RETURN')}")
    return [f"def {name}({', '.join(params)}):", *indent(body or ["pass"])]


def _call(block: Block, g: Generator) -> str:
    name = block.extra.get("name")
    if not isinstance(name, str) or name not in g.procedures:
        raise WorkspaceError(
            f"the function {str(name)[:40]!r} is not defined",
            block.id,
            words("program.no_function", name=str(name)[:40]),
        )
    count = len(_params(g.procedures[name]))
    args = ", ".join(g.value(block, f"ARG{i}") for i in range(count))
    return f"{g.names.get('procedure', name)}({args})"


@statement("procedures_callnoreturn")
def procedures_call_statement(block: Block, g: Generator) -> list[str]:
    return [_call(block, g)]


@value("procedures_callreturn")
def procedures_call_value(block: Block, g: Generator) -> str:
    return _call(block, g)


@statement("procedures_ifreturn")
def procedures_ifreturn(block: Block, g: Generator) -> list[str]:
    if g.procedure is None:
        raise WorkspaceError(
            "'if return' is only allowed inside a function",
            block.id,
            words("program.return_outside"),
        )
    result = g.value(block, "VALUE") if g.procedure.type == "procedures_defreturn" else ""
    return [f"if {g.value(block, 'CONDITION', 'False')}:", indent([f"return {result}".rstrip()])[0]]


def _count(block: Block, key: str, default: int) -> int:
    raw = block.extra.get(key, default)
    if isinstance(raw, bool) or not isinstance(raw, int) or not 0 <= raw <= MAX_ITEMS:
        raise WorkspaceError(f"block {block.type} has a malformed {key}", block.id)
    return raw
