"""The requests the UI's TypeScript makes and the ones its controls declare, read from the
sources: the generated client's `client.METHOD(path, {params: {path: {…}}})` calls (each
`{name}` of the path filled in with what `params.path` gives it), `untyped(METHOD, path…)`
(a plugin's) and an XMLHttpRequest's `open(…)` calls, the socket paths, and
`request(METHOD, path)` (webui/frontend/src/rights.ts).

A path is read as a shape: its literal text with a hole for every value (`${…}`) that is
not a constant of the same file (`const path = \\`…\\``) or a method returning one
(`this.path()`). A call's shape, holes matching any one path segment, covers a declaration
whose own holes are filled in: a generic call (`PUT /variables/{}`) is declared by a control
that makes one of its requests (`PUT /variables/frames.{}`), not the other way round."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

Shape = tuple[str | None, ...]  # literal text, or None for a value
CHANGING = frozenset({"POST", "PUT", "PATCH", "DELETE"})
OPENERS = {"(": ")", "[": "]", "{": "}"}
# After these a `/` starts a regular expression, not a division.
REGEX_AFTER = set("(,=:[!&|?{};+-*%<>~^") | {""}
CALL = re.compile(r"(?<![\w.$])(api|untyped)\s*(?=[<(])|\.open\s*(?=\()")
CLIENT_CALL = re.compile(r"(?<![\w$])client\.(GET|POST|PUT|PATCH|DELETE)\s*(?=\()")
PLACEHOLDER = re.compile(r"\{(\w+)\}")
IDENTIFIER = r"[A-Za-z_$][\w$]*"
DECLARED = re.compile(r"(?<![\w.$])request\s*(?=\()")
SOCKET_PATH = re.compile(r"^(?:/api)?/[\w./{}-]*(?:/ws|_ws|/_events)(?:\?.*)?$")


@dataclass(frozen=True)
class Request:
    file: str  # relative to the sources
    method: str  # the text of the method argument ("POST", or an expression)
    shape: Shape | None  # None: the path could not be read

    @property
    def literal(self) -> bool:
        return self.method.isupper() and self.method.isalpha()

    def text(self) -> str:
        return "?" if self.shape is None else "".join(p or "{}" for p in self.shape)

    def sample(self) -> str:
        """The declaration's path with a value in each hole."""
        assert self.shape is not None
        return "".join("x" if p is None else p for p in self.shape)

    def covers(self, declared: Request) -> bool:
        """Whether a control's declared request is one this call can make."""
        if self.shape is None or declared.shape is None or self.method != declared.method:
            return False
        pattern = "".join("[^/]+" if p is None else re.escape(p) for p in self.shape)
        return re.fullmatch(pattern, declared.sample()) is not None


def skip_code(text: str, i: int, stops: str) -> int:
    """The index of the first character of `stops` outside brackets, strings, templates,
    comments and regular expressions from `i` on (len(text) if none)."""
    depth: list[str] = []
    previous = ""
    while i < len(text):
        c = text[i]
        if not depth and c in stops:
            return i
        if c in "'\"":
            i = skip_string(text, i)
            previous = "a"
            continue
        if c == "`":
            i = skip_template(text, i)[0]
            previous = "a"
            continue
        if c == "/" and text[i + 1 : i + 2] == "/":
            i = text.find("\n", i)
            i = len(text) if i < 0 else i
            continue
        if c == "/" and text[i + 1 : i + 2] == "*":
            end = text.find("*/", i + 2)
            i = len(text) if end < 0 else end + 2
            continue
        if c == "/" and (previous in REGEX_AFTER or text[:i].rstrip().endswith("return")):
            i = skip_regex(text, i)
            previous = "a"
            continue
        if c in OPENERS:
            depth.append(OPENERS[c])
        elif depth and c == depth[-1]:
            depth.pop()
        elif c in ")]}":
            return i  # the caller's closing bracket
        if not c.isspace():
            previous = c if not (c.isalnum() or c in "_$") else "a"
        i += 1
    return i


def skip_string(text: str, i: int) -> int:
    quote, i = text[i], i + 1
    while i < len(text) and text[i] != quote:
        i += 2 if text[i] == "\\" else 1
    return i + 1


def skip_regex(text: str, i: int) -> int:
    i, in_class = i + 1, False
    while i < len(text):
        c = text[i]
        if c == "\\":
            i += 2
            continue
        if c == "[":
            in_class = True
        elif c == "]":
            in_class = False
        elif c == "/" and not in_class:
            break
        i += 1
    i += 1
    while i < len(text) and text[i].isalpha():
        i += 1
    return i


def skip_template(text: str, i: int) -> tuple[int, list[str | tuple[int, int]]]:
    """The index after a template literal starting at `i`, and its parts: literal text, or
    the (start, end) of each `${…}` expression."""
    parts: list[str | tuple[int, int]] = []
    i, literal = i + 1, ""
    while i < len(text):
        c = text[i]
        if c == "\\":
            literal += text[i + 1 : i + 2]
            i += 2
        elif c == "`":
            return i + 1, [*parts, literal] if literal else parts
        elif c == "$" and text[i + 1 : i + 2] == "{":
            if literal:
                parts.append(literal)
                literal = ""
            end = skip_code(text, i + 2, "}")
            parts.append((i + 2, end))
            i = end + 1
        else:
            literal += c
            i += 1
    raise ValueError("an unterminated template literal")


def arguments(text: str, i: int) -> tuple[list[str], int]:
    """The arguments of the call whose `(` is at `i`, as text, and the index after `)`."""
    found, i = [], i + 1
    while True:
        end = skip_code(text, i, ",)")
        if text[i:end].strip():
            found.append(text[i:end].strip())
        if end >= len(text) or text[end] == ")":
            return found, end + 1
        i = end + 1


class Source:
    def __init__(self, name: str, text: str) -> None:
        self.name = name
        self.text = text

    def shape(self, expression: str, at: int, depth: int = 0) -> Shape | None:
        """The path an expression makes, read in this file; None if it cannot be read."""
        e = expression.strip()
        if depth > 6:
            return None
        if len(e) >= 2 and e[0] in "'\"" and e[-1] == e[0]:
            return (e[1:-1],)
        if e.startswith("`") and skip_template(e, 0)[0] == len(e):
            shape: list[str | None] = []
            for part in skip_template(e, 0)[1]:
                if isinstance(part, str):
                    shape.append(part)
                else:
                    inner = self.shape(e[part[0] : part[1]], at, depth + 1)
                    shape.extend(inner if inner is not None else (None,))
            return tuple(shape)
        if re.fullmatch(r"[A-Za-z_$][\w$]*", e):
            return self._constant(e, at, depth)
        method = re.fullmatch(r"(?:this\.)?([A-Za-z_$][\w$]*)\([^()]*\)", e)
        if method:
            return self._returned(method.group(1), at, depth)
        return None

    def _constant(self, name: str, at: int, depth: int) -> Shape | None:
        found = self._constant_text(name, at)
        return None if found is None else self.shape(found[0], found[1], depth + 1)

    def _returned(self, name: str, at: int, depth: int) -> Shape | None:
        found = self._returned_text(name)
        return None if found is None else self.shape(found[0], found[1], depth + 1)

    def _constant_text(self, name: str, at: int) -> tuple[str, int] | None:
        """The expression a `const` of this name (the last before `at`) is set to."""
        definitions = list(re.finditer(rf"\bconst {re.escape(name)}(?::[^=]+)? = ", self.text))
        before = [d for d in definitions if d.start() < at] or definitions
        if not before:
            return None
        start = before[-1].end()
        return self.text[start : skip_code(self.text, start, ";")], start

    def _returned_text(self, name: str) -> tuple[str, int] | None:
        """The expression a method or function of this name returns."""
        head = re.search(
            rf"(?:^|\s)(?:private |function )?{re.escape(name)}\([^)]*\)(?::[^{{]+)?\{{\s*return ",
            self.text,
        )
        if head is None:
            return None
        start = head.end()
        return self.text[start : skip_code(self.text, start, ";")], start

    def entries(self, expression: str, at: int, depth: int = 0) -> dict[str, str]:
        """An object literal's entries (key -> the text of its value), read through spreads,
        constants and methods returning one; {} if it cannot be read."""
        e = expression.strip()
        if depth > 6:
            return {}
        if e.startswith("{") and skip_code(e, 1, "}") == len(e) - 1:
            found: dict[str, str] = {}
            i = 1
            while i < len(e) - 1:
                end = skip_code(e, i, ",}")
                item = e[i:end].strip()
                if item.startswith("..."):
                    found |= self.entries(item[3:], at, depth + 1)
                elif item:
                    key_end = skip_code(item, 0, ":")
                    key = item[:key_end].strip().strip("'\"")
                    found[key] = item[key_end + 1 :].strip() if key_end < len(item) else key
                i = end + 1
            return found
        named = None
        if re.fullmatch(IDENTIFIER, e):
            named = self._constant_text(e, at)
        elif method := re.fullmatch(rf"(?:this\.)?({IDENTIFIER})\(\)", e):
            named = self._returned_text(method.group(1))
        return {} if named is None else self.entries(named[0], named[1], depth + 1)

    def _filled(self, shape: Shape, values: dict[str, str], at: int) -> Shape:
        """A client path's shape with each `{name}` replaced by the shape of its value (a
        hole where that cannot be read)."""
        filled: list[str | None] = []
        for part in shape:
            if part is None:
                filled.append(None)
                continue
            for k, piece in enumerate(PLACEHOLDER.split(part)):
                if k % 2 == 0:
                    filled.extend([piece] if piece else [])
                    continue
                value = values.get(piece)
                inner = None if value is None else self.shape(value, at)
                filled.extend(inner if inner is not None else (None,))
        return tuple(filled)

    def calls(self) -> list[Request]:
        """Every call of the generated client, every untyped(…) and XMLHttpRequest open(…)
        call, but for their definitions."""
        found = []
        for match in CLIENT_CALL.finditer(code_only(self.text)):
            args, _ = arguments(self.text, match.end())
            if not args:
                continue
            shape = self.shape(args[0], match.start())
            options = self.entries(args[1], match.start()) if len(args) > 1 else {}
            params = self.entries(options.get("params", "{}"), match.start())
            values = self.entries(params.get("path", "{}"), match.start())
            if shape is not None:
                shape = self._filled(shape, values, match.start())
            found.append(Request(self.name, match.group(1), shape))
        for match in CALL.finditer(code_only(self.text)):
            i = match.end()
            if self.text[i] == "<":  # type arguments: api<Thing<Other>>(
                level = 0
                while True:
                    level += {"<": 1, ">": -1}.get(self.text[i], 0)
                    i += 1
                    if level == 0:
                        break
            args, _ = arguments(self.text, self.text.index("(", i))
            if len(args) < 2 or re.match(r"[\w$]+\s*:", args[0]):  # a signature, not a call
                continue
            method = args[0].strip("'\"")
            if match.group(0).startswith(".") and method not in CHANGING | {"GET"}:
                continue  # some other open(…)
            found.append(Request(self.name, method, self.shape(args[1], match.start())))
        return found

    def declared(self) -> list[Request]:
        found = []
        for match in DECLARED.finditer(code_only(self.text)):
            args, _ = arguments(self.text, match.end())
            if len(args) == 2 and re.fullmatch(r"\"[A-Z]+\"", args[0]):
                found.append(Request(self.name, args[0][1:-1], self.shape(args[1], match.start())))
        return found

    def socket_paths(self) -> list[Request]:
        """Every string or template in the code (inside templates too) that names a socket."""
        found = []
        for match in re.finditer(r"\"/[^\"\n]*\"|'/[^'\n]*'|`/[^`]*`", code_only(self.text)):
            if match.group(0)[0] == "`" and not self._whole_template(match.start(), match.end()):
                continue  # the end of one template and the start of the next
            shape = self.shape(match.group(0), match.start())
            if shape is not None and SOCKET_PATH.match("".join(p or "{}" for p in shape)):
                found.append(Request(self.name, "WS", shape))
        return found

    def _whole_template(self, start: int, end: int) -> bool:
        try:
            return skip_template(self.text, start)[0] == end
        except ValueError:
            return False


def code_only(text: str) -> str:
    """The text with its comments blanked (same length, so indices stay)."""
    out = list(text)
    for start, stop in comments(text):
        out[start:stop] = " " * (stop - start)
    return "".join(out)


def comments(text: str) -> list[tuple[int, int]]:
    found, i = [], 0
    while i < len(text):
        c = text[i]
        if c in "'\"":
            i = skip_string(text, i)
        elif c == "`":
            i = skip_template(text, i)[0]
        elif text.startswith("//", i):
            end = text.find("\n", i)
            end = len(text) if end < 0 else end
            found.append((i, end))
            i = end
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = len(text) if end < 0 else end + 2
            found.append((i, end))
            i = end
        elif c == "/" and text[:i].rstrip()[-1:] in REGEX_AFTER | {""}:
            i = skip_regex(text, i)
        else:
            i += 1
    return found


def sources(root: Path) -> list[Source]:
    return [
        Source(str(path.relative_to(root)), path.read_text())
        for path in sorted(root.rglob("*.ts"))
        if "i18n" not in path.parts
    ]
