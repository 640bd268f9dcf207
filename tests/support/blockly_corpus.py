"""The corpus of the Blockly oracle test (tests/unit/test_blockly_oracle.py): workspaces of
Blockly's standard blocks, every mode of each, as Blockly saves them. Each prints what its
blocks compute; where Blockly picks at random, only what does not depend on the pick (a
one-item list, or whether the pick is in the list)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from openpendant.runtime.bench.harness import blocks as wb

Block = dict[str, Any]
Workspace = dict[str, Any]

# Building workspaces (each block made anew: ids are unique) ------------------------------------


def num(value: float) -> Block:
    return wb.number(value)


def txt(value: str) -> Block:
    return wb.text(value)


def var(name: str) -> Block:
    return wb.var(name)


def blk(kind: str, fields: dict[str, Any] | None = None, **inputs: Block) -> Block:
    return wb.block(kind, fields, **inputs)


def items(*values: float | str) -> Block:
    """'create list with' numbers and texts."""
    made = blk(
        "lists_create_with",
        None,
        **{f"ADD{i}": txt(v) if isinstance(v, str) else num(v) for i, v in enumerate(values)},
    )
    made["extraState"] = {"itemCount": len(values)}
    return made


def show(value: Block) -> Block:
    return blk("text_print", TEXT=value)


def assign(name: str, value: Block) -> Block:
    return blk("variables_set", {"VAR": {"id": name}}, VALUE=value)


def compare(op: str, a: Block, b: Block) -> Block:
    return blk("logic_compare", {"OP": op}, A=a, B=b)


def both(a: Block, b: Block) -> Block:
    return blk("logic_operation", {"OP": "AND"}, A=a, B=b)


def contains(where: Block, item: Block) -> Block:
    found = blk("lists_indexOf", {"END": "FIRST"}, VALUE=where, FIND=item)
    return compare("GT", found, num(0))


def size(of: Block) -> Block:
    return blk("lists_length", VALUE=of)


def last(of: Block) -> Block:
    return blk("lists_getIndex", {"MODE": "GET", "WHERE": "LAST"}, VALUE=of)


def program(
    *steps: Block, variables: tuple[str, ...] = (), functions: tuple[Block, ...] = ()
) -> Workspace:
    main = wb.stack(*steps)
    main.update(x=0, y=0)
    for i, function in enumerate(functions):
        function.update(x=0, y=-300 * (i + 1))
    return wb.workspace(*functions, main, variables=variables)


def shows(*values: Block, variables: tuple[str, ...] = ()) -> Workspace:
    """A program printing each value."""
    return program(*[show(v) for v in values], variables=variables)


CORPUS: dict[str, Workspace] = {}


def case(name: str, workspace: Workspace) -> None:
    assert name not in CORPUS, name
    CORPUS[name] = workspace


WHERE = ("FROM_START", "FROM_END", "FIRST", "LAST", "RANDOM")
NUMBERED = ("FROM_START", "FROM_END")  # Blockly's blocks have a number input only for these


def at(where: str, number: float, name: str = "AT") -> dict[str, Block]:
    return {name: num(number)} if where in NUMBERED else {}


# Lists: positions ------------------------------------------------------------------------------


def lists_get_index() -> None:
    for mode in ("GET", "GET_REMOVE", "REMOVE"):
        for where in WHERE:
            got = blk(
                "lists_getIndex",
                {"MODE": mode, "WHERE": where},
                VALUE=var("xs"),
                **at(where, 2),
            )
            steps = [assign("xs", items(10, 20, 30, 40))]
            if mode == "REMOVE":
                got["extraState"] = {"isStatement": True}
                steps.append(got)
            elif where == "RANDOM":
                steps += [assign("x", got), show(contains(items(10, 20, 30, 40), var("x")))]
            else:
                steps.append(show(got))
            if where != "RANDOM":
                steps.append(show(var("xs")))
            elif mode != "GET":
                steps.append(show(size(var("xs"))))
            if where == "RANDOM" and mode == "GET_REMOVE":
                total = blk("math_on_list", {"OP": "SUM"}, LIST=var("xs"))
                steps.append(show(blk("math_arithmetic", {"OP": "ADD"}, A=total, B=var("x"))))
            case(f"lists_getIndex {mode} {where}", program(*steps, variables=("xs", "x")))
    case(
        "lists_getIndex GET RANDOM of one item",
        shows(blk("lists_getIndex", {"MODE": "GET", "WHERE": "RANDOM"}, VALUE=items(7))),
    )
    case(
        "lists_getIndex at a computed position",
        program(
            assign("n", blk("math_arithmetic", {"OP": "ADD"}, A=num(1), B=num(2))),
            *[
                show(
                    blk(
                        "lists_getIndex",
                        {"MODE": "GET", "WHERE": where},
                        VALUE=items(10, 20, 30, 40),
                        AT=var("n"),
                    )
                )
                for where in NUMBERED
            ],
            variables=("n",),
        ),
    )


def lists_set_index() -> None:
    for mode in ("SET", "INSERT"):
        for where in WHERE:
            changed = blk(
                "lists_setIndex",
                {"MODE": mode, "WHERE": where},
                LIST=var("xs"),
                TO=num(99),
                **at(where, 1),
            )
            steps = [assign("xs", items(10, 20, 30)), changed]
            if where != "RANDOM":
                steps.append(show(var("xs")))
            else:
                steps += [show(size(var("xs"))), show(contains(var("xs"), num(99)))]
                if mode == "INSERT":  # Blockly picks among the items, never after the last
                    steps.append(show(last(var("xs"))))
            case(f"lists_setIndex {mode} {where}", program(*steps, variables=("xs",)))
    for where, position in (("FROM_END", 2), ("FROM_END", 3), ("FROM_START", 4)):
        case(
            f"lists_setIndex INSERT {where} {position}",
            program(
                assign("xs", items(10, 20, 30)),
                blk(
                    "lists_setIndex",
                    {"MODE": "INSERT", "WHERE": where},
                    LIST=var("xs"),
                    AT=num(position),
                    TO=num(99),
                ),
                show(var("xs")),
                variables=("xs",),
            ),
        )
    starts: dict[str, Callable[[], Block]] = {
        "an empty list": lambda: blk("lists_create_empty"),
        "one item": lambda: items(7),
    }
    for name, start in starts.items():
        for mode in ("SET", "INSERT"):
            if mode == "SET" and name == "an empty list":
                continue  # an error in both
            case(
                f"lists_setIndex {mode} RANDOM in {name}",
                program(
                    assign("xs", start()),
                    blk(
                        "lists_setIndex",
                        {"MODE": mode, "WHERE": "RANDOM"},
                        LIST=var("xs"),
                        TO=num(99),
                    ),
                    show(var("xs")),
                    variables=("xs",),
                ),
            )


def sub_sequences() -> None:
    sources: dict[str, tuple[str, Callable[[], Block]]] = {
        "lists_getSublist": ("LIST", lambda: items(1, 2, 3, 4, 5, 6)),
        "text_getSubstring": ("STRING", lambda: txt("abcdef")),
    }
    for kind, (source, whole) in sources.items():
        for where1 in ("FROM_START", "FROM_END", "FIRST"):
            for where2 in ("FROM_START", "FROM_END", "LAST"):
                part = blk(
                    kind,
                    {"WHERE1": where1, "WHERE2": where2},
                    **{source: whole()},
                    **at(where1, 2 if where1 == "FROM_START" else 5, "AT1"),
                    **at(where2, 4 if where2 == "FROM_START" else 2, "AT2"),
                )
                case(f"{kind} {where1} {where2}", shows(part))
        # Positions beyond the ends take Python's slice bounds, as Blockly's code does.
        case(
            f"{kind} positions beyond the ends",
            shows(
                *[
                    blk(
                        kind,
                        {"WHERE1": where1, "WHERE2": where2},
                        **{source: whole()},
                        **at(where1, at1, "AT1"),
                        **at(where2, at2, "AT2"),
                    )
                    for where1, at1, where2, at2 in (
                        ("FIRST", 0, "FROM_END", 6),
                        ("FIRST", 0, "FROM_END", 7),
                        ("FIRST", 0, "FROM_END", 8),
                        ("FIRST", 0, "FROM_END", 12),
                        ("FROM_END", 9, "LAST", 0),
                        ("FROM_START", 2, "FROM_START", 9),
                        ("FROM_START", 5, "FROM_START", 2),
                    )
                ]
            ),
        )


def text_char_at() -> None:
    for where in WHERE:
        letter = blk("text_charAt", {"WHERE": where}, VALUE=txt("hello"), **at(where, 2))
        if where == "RANDOM":
            found = blk("text_indexOf", {"END": "FIRST"}, VALUE=txt("hello"), FIND=letter)
            one = blk("text_charAt", {"WHERE": "RANDOM"}, VALUE=txt("z"))
            case(f"text_charAt {where}", shows(compare("GT", found, num(0)), one))
        else:
            case(f"text_charAt {where}", shows(letter))


# Math ------------------------------------------------------------------------------------------


def math_number_property() -> None:
    numbers: dict[str, tuple[float, ...]] = {
        "EVEN": (4, 7, 0, -2, 2.5),
        "ODD": (7, 4, -3, 2.5),
        # 999999999989 is the largest prime below 10**12, 1000000000039 the smallest above.
        "PRIME": (2, 3, 4, 1, 0, -7, 91, 97, 7.5, 999_999_999_989, 1_000_000_000_039),
        "WHOLE": (3, 3.5, -2),
        "POSITIVE": (5, 0, -5),
        "NEGATIVE": (5, 0, -5),
    }
    for prop, values in numbers.items():
        checked = [num(v) for v in values]
        if prop == "PRIME":
            checked += [
                blk("math_arithmetic", {"OP": "DIVIDE"}, A=num(14), B=num(2)),  # 7.0
                num(1_000_003 * 1_000_033),
            ]
        case(
            f"math_number_property {prop}",
            shows(
                *[
                    blk("math_number_property", {"PROPERTY": prop}, NUMBER_TO_CHECK=n)
                    for n in checked
                ]
            ),
        )
    case(
        "math_number_property DIVISIBLE_BY",
        shows(
            *[
                blk(
                    "math_number_property",
                    {"PROPERTY": "DIVISIBLE_BY"},
                    NUMBER_TO_CHECK=num(a),
                    DIVISOR=num(b),
                )
                for a, b in ((12, 4), (12, 5), (-12, 4), (7.5, 2.5))
            ]
        ),
    )


def math_on_list() -> None:
    for op in ("SUM", "MIN", "MAX", "AVERAGE", "MEDIAN", "MODE", "STD_DEV"):
        case(
            f"math_on_list {op}",
            shows(
                blk("math_on_list", {"OP": op}, LIST=items(3, 1, 4, 1, 5, 9, 2, 6)),
                blk("math_on_list", {"OP": op}, LIST=items(2.5, 7, -1)),
                blk("math_on_list", {"OP": op}, LIST=items(1, 2, 2, 1, 3)),
            ),
        )
    case(
        "math_on_list RANDOM",
        program(
            assign("x", blk("math_on_list", {"OP": "RANDOM"}, LIST=items(3, 1, 4))),
            show(contains(items(3, 1, 4), var("x"))),
            show(blk("math_on_list", {"OP": "RANDOM"}, LIST=items(7))),
            variables=("x",),
        ),
    )
    # Blockly's mean and median are of the numbers in the list; its modes are of any items.
    case(
        "math_on_list of a list with texts",
        shows(
            blk("math_on_list", {"OP": "AVERAGE"}, LIST=items(1, "a", 3)),
            blk("math_on_list", {"OP": "MEDIAN"}, LIST=items(5, "x", 1, 3)),
            blk("math_on_list", {"OP": "MODE"}, LIST=items("b", "a", "b", 1)),
        ),
    )
    case(
        "math_on_list of an empty list",
        shows(
            *[
                blk("math_on_list", {"OP": op}, LIST=blk("lists_create_empty"))
                for op in ("SUM", "AVERAGE", "MEDIAN", "MODE", "STD_DEV")
            ]
        ),
    )


def math_single() -> None:
    values: dict[str, tuple[float, ...]] = {
        "ROOT": (9, 2),
        "ABS": (-4, 2.5),
        "NEG": (4, -2.5, 0),
        "LN": (1, 10),
        "LOG10": (1000, 2),
        "EXP": (0, 1),
        "POW10": (2, -1),
    }
    for op, numbers in values.items():
        arguments = [num(n) for n in numbers]
        if op == "NEG":  # of an integer computed, not written
            arguments.append(blk("math_arithmetic", {"OP": "MULTIPLY"}, A=num(2), B=num(3)))
        case(
            f"math_single {op}",
            shows(*[blk("math_single", {"OP": op}, NUM=n) for n in arguments]),
        )


def math_round() -> None:
    for op in ("ROUND", "ROUNDUP", "ROUNDDOWN"):
        case(
            f"math_round {op}",
            shows(
                *[blk("math_round", {"OP": op}, NUM=num(n)) for n in (3.5, 2.5, -2.5, 3.1, -3.1, 4)]
            ),
        )


def other_math() -> None:
    case(
        "math_trig every function",
        shows(
            *[
                blk("math_trig", {"OP": op}, NUM=num(n))
                for op, n in (
                    ("SIN", 30),
                    ("COS", 60),
                    ("TAN", 45),
                    ("ASIN", 0.5),
                    ("ACOS", 0.5),
                    ("ATAN", 1),
                )
            ]
        ),
    )
    case(
        "math_constant every constant",
        shows(
            *[
                blk("math_constant", {"CONSTANT": c})
                for c in ("PI", "E", "GOLDEN_RATIO", "SQRT2", "SQRT1_2", "INFINITY")
            ]
        ),
    )
    case(
        "math_arithmetic every operation",
        shows(
            *[
                blk("math_arithmetic", {"OP": op}, A=num(a), B=num(b))
                for op, a, b in (
                    ("ADD", 2, 3),
                    ("ADD", 0.1, 0.2),
                    ("MINUS", 2, 5),
                    ("MULTIPLY", 4, 2.5),
                    ("DIVIDE", 7, 2),
                    ("DIVIDE", 6, 3),
                    ("POWER", 2, 10),
                    ("POWER", 2, -1),
                )
            ]
        ),
    )
    case(
        "math_number, math_modulo, math_constrain, math_atan2",
        shows(
            num(0),
            num(-2.5),
            num(1e6),
            num(0.1),
            blk("math_modulo", DIVIDEND=num(-7), DIVISOR=num(3)),
            blk("math_modulo", DIVIDEND=num(7.5), DIVISOR=num(2)),
            *[
                blk("math_constrain", VALUE=num(v), LOW=num(1), HIGH=num(10))
                for v in (50, -5, 5, 2.5)
            ],
            blk("math_atan2", X=num(1), Y=num(1)),
            blk("math_atan2", X=num(-1), Y=num(0)),
        ),
    )
    case(
        "math_random_int, math_random_float",
        program(
            show(blk("math_random_int", FROM=num(5), TO=num(5))),
            assign("x", blk("math_random_int", FROM=num(1), TO=num(6))),
            show(both(compare("GTE", var("x"), num(1)), compare("LTE", var("x"), num(6)))),
            show(blk("math_number_property", {"PROPERTY": "WHOLE"}, NUMBER_TO_CHECK=var("x"))),
            assign("f", blk("math_random_float")),
            show(both(compare("GTE", var("f"), num(0)), compare("LT", var("f"), num(1)))),
            variables=("x", "f"),
        ),
    )
    case(
        "math_change",
        program(
            assign("x", num(5)),
            blk("math_change", {"VAR": {"id": "x"}}, DELTA=num(2)),
            show(var("x")),
            blk("math_change", {"VAR": {"id": "y"}}, DELTA=num(1.5)),
            show(var("y")),
            variables=("x", "y"),
        ),
    )


# Text and lists --------------------------------------------------------------------------------


def index_of() -> None:
    for end in ("FIRST", "LAST"):
        case(
            f"text_indexOf {end}",
            shows(
                *[
                    blk("text_indexOf", {"END": end}, VALUE=txt("banana"), FIND=txt(s))
                    for s in ("an", "x", "", "banana")
                ]
            ),
        )
        case(
            f"lists_indexOf {end}",
            shows(
                *[
                    blk("lists_indexOf", {"END": end}, VALUE=items(1, 2, 1, "a"), FIND=find)
                    for find in (num(1), num(5), txt("a"))
                ]
            ),
        )


def lists_sort() -> None:
    lists: dict[str, Callable[[], Block]] = {
        "NUMERIC": lambda: items(3, 1, 2.5, -4, 10),
        "TEXT": lambda: items("b", "a", "C", "10", "9"),
        "IGNORE_CASE": lambda: items("b", "a", "C", "B"),
        "NUMERIC of texts": lambda: items("10", "9", "x", "-1", "2.5"),
    }
    for name, values in lists.items():
        kind = name.split()[0]
        case(
            f"lists_sort {name}",
            shows(
                *[
                    blk("lists_sort", {"TYPE": kind, "DIRECTION": direction}, LIST=values())
                    for direction in ("1", "-1")
                ]
            ),
        )


def lists_split() -> None:
    case(
        "lists_split SPLIT",
        shows(
            blk("lists_split", {"MODE": "SPLIT"}, INPUT=txt("a,b,,c"), DELIM=txt(",")),
            blk("lists_split", {"MODE": "SPLIT"}, INPUT=txt("one two"), DELIM=txt(" ")),
        ),
    )
    case(
        "lists_split JOIN",
        shows(
            blk("lists_split", {"MODE": "JOIN"}, INPUT=items("a", "b", "c"), DELIM=txt("-")),
            blk("lists_split", {"MODE": "JOIN"}, INPUT=items("x"), DELIM=txt(", ")),
        ),
    )


def other_text() -> None:
    joined = [blk("text_join") for _ in range(4)]
    for count, joining in enumerate(joined):
        joining["extraState"] = {"itemCount": count}
        joining["inputs"] = {
            f"ADD{i}": {"block": v}
            for i, v in enumerate(
                [txt("a"), num(1), blk("logic_boolean", {"BOOL": "TRUE"})][:count]
            )
        }
    case("text_join of 0 to 3 items", shows(*joined))
    case(
        "text blocks",
        program(
            assign("s", txt("ab")),
            blk("text_append", {"VAR": {"id": "s"}}, TEXT=num(3)),
            show(var("s")),
            show(blk("text_length", VALUE=txt("hello"))),
            show(blk("text_isEmpty", VALUE=txt(""))),
            show(blk("text_isEmpty", VALUE=txt("x"))),
            *[
                show(blk("text_changeCase", {"CASE": c}, TEXT=txt("hello wORLD")))
                for c in ("UPPERCASE", "LOWERCASE", "TITLECASE")
            ],
            *[
                show(blk("text_trim", {"MODE": m}, TEXT=txt("  x y  ")))
                for m in ("BOTH", "LEFT", "RIGHT")
            ],
            show(blk("text_count", TEXT=txt("banana"), SUB=txt("an"))),
            show(blk("text_replace", TEXT=txt("banana"), FROM=txt("a"), TO=txt("o"))),
            show(blk("text_reverse", TEXT=txt("abc"))),
            show(txt('it\'s "quoted"')),
            variables=("s",),
        ),
    )


def other_lists() -> None:
    with_a_hole = items(1, 2)
    with_a_hole["extraState"] = {"itemCount": 3}
    case(
        "list blocks",
        shows(
            blk("lists_create_empty"),
            with_a_hole,
            blk("lists_repeat", ITEM=txt("x"), NUM=num(3)),
            size(items(1, 2, 3)),
            blk("lists_isEmpty", VALUE=blk("lists_create_empty")),
            blk("lists_isEmpty", VALUE=items(1)),
            blk("lists_reverse", LIST=items(1, 2, 3)),
        ),
    )


# Logic, loops and functions --------------------------------------------------------------------


def logic() -> None:
    ops = ("EQ", "NEQ", "LT", "LTE", "GT", "GTE")
    case(
        "logic blocks",
        shows(
            *[compare(op, num(1), num(2)) for op in ops],
            *[compare(op, num(2), num(2)) for op in ops],
            *[
                blk(
                    "logic_operation",
                    {"OP": op},
                    A=blk("logic_boolean", {"BOOL": a}),
                    B=blk("logic_boolean", {"BOOL": b}),
                )
                for op in ("AND", "OR")
                for a, b in (("TRUE", "FALSE"), ("TRUE", "TRUE"))
            ],
            blk("logic_negate", BOOL=blk("logic_boolean", {"BOOL": "FALSE"})),
            blk("logic_null"),
            blk(
                "logic_ternary",
                IF=compare("LT", num(1), num(2)),
                THEN=txt("yes"),
                ELSE=txt("no"),
            ),
        ),
    )


def counting(start: Block, stop: Block, step: Block, *before: Block) -> Workspace:
    loop = blk(
        "controls_for",
        {"VAR": {"id": "i"}},
        FROM=start,
        TO=stop,
        BY=step,
        DO=show(var("i")),
    )
    return program(*before, loop, variables=("i", "a", "b", "s"))


def loops() -> None:
    for start, stop, step in ((10, 1, -3), (1, 10, -3), (5, 1, 1), (1, 3, 5), (2, 1, -0.5)):
        case(
            f"controls_for from {start} to {stop} by {step}",
            counting(num(start), num(stop), num(step)),
        )
    case(
        "controls_for from variables with a negative step",
        counting(
            var("a"),
            var("b"),
            var("s"),
            assign("a", num(10)),
            assign("b", num(2)),
            assign("s", num(-4)),
        ),
    )
    case(
        "controls_for from computed values counting up by a fraction",
        counting(
            blk("math_arithmetic", {"OP": "MINUS"}, A=num(2), B=num(1)),
            num(2),
            blk("math_arithmetic", {"OP": "DIVIDE"}, A=num(-1), B=num(4)),
        ),
    )
    counter = assign("n", num(0))
    grow = blk("math_change", {"VAR": {"id": "n"}}, DELTA=num(1))
    until = blk(
        "controls_whileUntil",
        {"MODE": "UNTIL"},
        BOOL=compare("GTE", var("n"), num(3)),
        DO=wb.stack(grow, show(var("n"))),
    )
    while_ = blk(
        "controls_whileUntil",
        {"MODE": "WHILE"},
        BOOL=compare("GT", var("n"), num(0)),
        DO=wb.stack(blk("math_change", {"VAR": {"id": "n"}}, DELTA=num(-2)), show(var("n"))),
    )
    case("controls_whileUntil", program(counter, until, while_, variables=("n",)))
    flow = blk(
        "controls_forEach",
        {"VAR": {"id": "x"}},
        LIST=items(1, 2, 3, 4, 5),
        DO=wb.stack(
            blk(
                "controls_if",
                IF0=compare("EQ", var("x"), num(2)),
                DO0=blk("controls_flow_statements", {"FLOW": "CONTINUE"}),
            ),
            blk(
                "controls_if",
                IF0=compare("EQ", var("x"), num(4)),
                DO0=blk("controls_flow_statements", {"FLOW": "BREAK"}),
            ),
            show(var("x")),
        ),
    )
    repeat = blk(
        "controls_repeat_ext",
        TIMES=num(3),
        DO=show(txt("again")),
    )
    choose = blk(
        "controls_if",
        IF0=compare("LT", var("x"), num(0)),
        DO0=show(txt("negative")),
        IF1=compare("EQ", var("x"), num(0)),
        DO1=show(txt("zero")),
        ELSE=show(txt("positive")),
    )
    choose["extraState"] = {"elseIfCount": 1, "hasElse": True}
    case(
        "controls_forEach, flow statements, repeat and if",
        program(flow, repeat, assign("x", num(0)), choose, variables=("x",)),
    )


def procedures() -> None:
    factorial = blk(
        "procedures_defreturn",
        {"NAME": "factorial"},
        STACK=blk(
            "procedures_ifreturn",
            CONDITION=compare("LTE", var("k"), num(1)),
            VALUE=num(1),
        ),
        RETURN=blk(
            "math_arithmetic",
            {"OP": "MULTIPLY"},
            A=var("k"),
            B=blk(
                "procedures_callreturn",
                ARG0=blk("math_arithmetic", {"OP": "MINUS"}, A=var("k"), B=num(1)),
            ),
        ),
    )
    factorial["extraState"] = {"params": [{"name": "k", "id": "k"}]}
    recursive = factorial["inputs"]["RETURN"]["block"]["inputs"]["B"]["block"]
    recursive["extraState"] = {"name": "factorial", "params": ["k"]}
    called = blk("procedures_callreturn", ARG0=num(10))
    called["extraState"] = {"name": "factorial", "params": ["k"]}
    case(
        "procedures_defreturn, recursive, with if-return",
        program(show(called), variables=("k",), functions=(factorial,)),
    )
    add = blk(
        "procedures_defnoreturn",
        {"NAME": "add to total"},
        STACK=wb.stack(
            blk(
                "procedures_ifreturn",
                CONDITION=compare("LT", var("amount"), num(0)),
            ),
            blk("math_change", {"VAR": {"id": "total"}}, DELTA=var("amount")),
        ),
    )
    add["extraState"] = {"params": [{"name": "amount", "id": "amount"}]}
    calls = []
    for amount in (5, -3, 2.5):
        made = blk("procedures_callnoreturn", ARG0=num(amount))
        made["extraState"] = {"name": "add to total", "params": ["amount"]}
        calls.append(made)
    case(
        "procedures_defnoreturn changing a global, with if-return",
        program(
            assign("total", num(0)),
            *calls,
            show(var("total")),
            variables=("total", "amount"),
            functions=(add,),
        ),
    )


for build in (
    lists_get_index,
    lists_set_index,
    sub_sequences,
    text_char_at,
    math_number_property,
    math_on_list,
    math_single,
    math_round,
    other_math,
    index_of,
    lists_sort,
    lists_split,
    other_text,
    other_lists,
    logic,
    loops,
    procedures,
):
    build()
