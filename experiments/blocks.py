"""Generated blocks in Markdown docs: find them, check them against a fresh rendering, rewrite.

A block is the text between `<!-- generated:NAME -->` and `<!-- /generated:NAME -->`, each
marker on a line of its own. Checking compares a doc's block with the freshly rendered text
number by number: every mismatch names the file, the line, the block, the number's position
on the line and both values, so a reader sees at once which figure moved and by how much.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

BLOCK = re.compile(
    r"^<!-- generated:(?P<name>[\w.-]+) -->\n(?P<body>.*?)^<!-- /generated:(?P=name) -->$",
    re.M | re.S,
)
OPEN = re.compile(r"^<!-- (/?)generated:([\w.-]+) -->$", re.M)
NUMBER = re.compile(r"[−-]?\d[\d,]*(?:\.\d+)?(?:\s?×\s?10[⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+)?")


class BlockError(ValueError):
    """A doc whose markers do not pair up; the message names the file and line."""


@dataclass(frozen=True)
class Block:
    name: str
    body: str
    line: int  # 1-based line of the first body line


def find_blocks(text: str, where: str = "") -> list[Block]:
    """Every generated block of a doc, in order; unpaired or nested markers raise."""
    stack: list[tuple[str, int]] = []
    for m in OPEN.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        closing, name = m.group(1) == "/", m.group(2)
        if not closing:
            if stack:
                raise BlockError(f"{where}:{line}: block {name!r} opens inside {stack[-1][0]!r}")
            stack.append((name, line))
        elif not stack or stack[-1][0] != name:
            raise BlockError(f"{where}:{line}: /generated:{name} closes no open block")
        else:
            stack.pop()
    if stack:
        raise BlockError(f"{where}:{stack[-1][1]}: block {stack[-1][0]!r} is never closed")
    return [
        Block(m.group("name"), m.group("body"), text.count("\n", 0, m.start("body")) + 1)
        for m in BLOCK.finditer(text)
    ]


def compare_block(block: Block, fresh: str, where: str) -> list[str]:
    """Differences between a doc's block and its fresh rendering, number by number."""
    if block.body == fresh:
        return []
    old_lines, new_lines = block.body.splitlines(), fresh.splitlines()
    out: list[str] = []
    for i in range(max(len(old_lines), len(new_lines))):
        old = old_lines[i] if i < len(old_lines) else ""
        new = new_lines[i] if i < len(new_lines) else ""
        if old == new:
            continue
        place = f"{where}:{block.line + i} [{block.name}]"
        old_nums, new_nums = NUMBER.findall(old), NUMBER.findall(new)
        if len(old_nums) == len(new_nums) and NUMBER.sub("#", old) == NUMBER.sub("#", new):
            for k, (a, b) in enumerate(zip(old_nums, new_nums, strict=True)):
                if a != b:
                    out.append(f"{place} number {k + 1} on the line: doc {a}, fresh run {b}")
        else:
            out.append(f"{place} line differs: doc {old.strip()!r}, fresh run {new.strip()!r}")
    return out


def check_docs(root: Path, docs: Iterable[str], rendered: Mapping[str, str]) -> list[str]:
    """Every block of every doc against its fresh rendering; blocks no renderer knows and
    rendered blocks no doc carries are reported too."""
    problems: list[str] = []
    seen: set[str] = set()
    for doc in docs:
        text = (root / doc).read_text(encoding="utf-8")
        for block in find_blocks(text, doc):
            seen.add(block.name)
            if block.name not in rendered:
                problems.append(f"{doc}:{block.line} [{block.name}] no such generated block")
                continue
            problems += compare_block(block, rendered[block.name], doc)
    problems += [
        f"block {n!r} is rendered but no doc carries it" for n in rendered if n not in seen
    ]
    return problems


def replace_blocks(text: str, rendered: Mapping[str, str], where: str = "") -> tuple[str, int]:
    """The doc with every block's body replaced by its rendering; and how many changed."""
    find_blocks(text, where)  # the markers pair up
    changed = 0

    def sub(m: re.Match[str]) -> str:
        nonlocal changed
        name = m.group("name")
        if name not in rendered:
            raise BlockError(f"{where}: no renderer for block {name!r}")
        body = rendered[name]
        if not body.endswith("\n"):
            body += "\n"
        changed += body != m.group("body")
        return f"<!-- generated:{name} -->\n{body}<!-- /generated:{name} -->"

    return BLOCK.sub(sub, text), changed


def write_docs(root: Path, docs: Iterable[str], rendered: Mapping[str, str]) -> int:
    changed = 0
    for doc in docs:
        path = root / doc
        text, n = replace_blocks(path.read_text(encoding="utf-8"), rendered, doc)
        if n:
            path.write_text(text, encoding="utf-8")
        changed += n
    return changed
