"""Every link in the README and docs/ reaches what it names (issue 33): a file of the
repository, and a heading of it where the link has an anchor. A link to a file that moved or a
heading that was renamed fails here, not in a reader's browser."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LINK = re.compile(r"!?\[(?:[^\]\\]|\\.)*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
HEADING = re.compile(r"^(#{1,6})\s+(.+?)\s*#*\s*$")
FENCE = re.compile(r"^\s*(```|~~~)")


def documents() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def prose(path: Path) -> list[tuple[int, str]]:
    """The lines outside fenced code blocks, numbered (a link in an example is not one)."""
    lines, fenced = [], False
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if FENCE.match(line):
            fenced = not fenced
        elif not fenced:
            lines.append((number, line))
    return lines


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, markup and punctuation dropped, spaces as
    hyphens."""
    text = re.sub(r"`([^`]*)`", r"\1", heading)
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)
    text = re.sub(r"[^\w\- ]", "", text.lower())
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    found = set()
    for _, line in prose(path):
        match = HEADING.match(line)
        if not match:
            continue
        base = slug(match.group(2))
        count = seen.get(base, 0)
        seen[base] = count + 1
        found.add(base if count == 0 else f"{base}-{count}")
    return found


def broken(path: Path) -> list[str]:
    problems = []
    for number, line in prose(path):
        for target in LINK.findall(line):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
                continue
            file_part, _, anchor = target.partition("#")
            linked = (path.parent / file_part).resolve() if file_part else path
            where = f"{path.relative_to(ROOT)}:{number}: {target}"
            if not linked.exists():
                problems.append(f"{where}: no such file")
            elif anchor and linked.suffix == ".md" and anchor not in anchors(linked):
                problems.append(f"{where}: no such heading")
    return problems


def test_every_link_of_the_readme_and_docs_reaches_its_file_and_heading() -> None:
    problems = [p for document in documents() for p in broken(document)]
    assert problems == []


def test_the_check_finds_a_missing_file_and_a_renamed_heading(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    (tmp_path / "other.md").write_text("# Other\n\n## Its `parts`, in order\n")
    page.write_text(
        "# Page\n\n[ok](other.md#its-parts-in-order) [self](#page)\n"
        "```\n[in an example](nowhere.md)\n```\n"
        "[gone](missing.md) [renamed](other.md#its-old-name)\n"
    )
    global ROOT
    saved, ROOT = ROOT, tmp_path
    try:
        found = broken(page)
    finally:
        ROOT = saved
    assert found == [
        "page.md:7: missing.md: no such file",
        "page.md:7: other.md#its-old-name: no such heading",
    ]
