"""Text transformations of the documentation build (pure functions, tested in tests/test_docs.py)."""

from __future__ import annotations

import re

__all__ = ["mark_headings", "escape_bars", "INCLUDE_MARKERS"]

#: What a page's ``{include}`` of a section of README.md looks for (see :func:`mark_headings`).
INCLUDE_MARKERS = re.compile(r'<!-- (before|after): (.+?) -->')


def mark_headings(text: str) -> str:
    """Put ``<!-- before: TITLE -->`` and ``<!-- after: TITLE -->`` around every heading of a markdown
    file (outside code fences), so that a page can include one section exactly, by its full title:
    ``:start-after: "<!-- after: TITLE -->"`` and ``:end-before: "<!-- before: NEXT TITLE -->"``."""
    out, fence = [], None
    for line in text.split("\n"):
        stripped = line.lstrip()
        if stripped.startswith(("```", "~~~")):
            mark = stripped[:3]
            fence = None if fence == mark else (fence or mark)
        m = None if fence else re.match(r"^#{1,6} +(.+?) *$", line)
        if m:
            out += [f"<!-- before: {m.group(1)} -->", line, f"<!-- after: {m.group(1)} -->"]
        else:
            out.append(line)
    return "\n".join(out)


_LITERAL = re.compile(r"(``.+?``|`[^`]*`)")


def escape_bars(lines: list[str]) -> list[str]:
    """Escape ``|`` in docstring prose, where the package writes absolute values (``|k|``, ``|phi_hat|^2``)
    that reStructuredText would read as substitution references; inline literals, roles, literal
    blocks, directive bodies (math), tables and line blocks are left as they are."""
    out = []
    block = None    # indentation of the line that opened the literal block or directive we are in
    pending = None  # indentation of a line ending with '::' or of a directive, whose body may follow
    for line in lines:
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if block is not None:
            if not stripped or indent > block:
                out.append(line)
                continue
            block = None
        if pending is not None and stripped:
            if indent > pending:
                block, pending = pending, None
                out.append(line)
                continue
            pending = None
        if stripped.endswith("::") or stripped.startswith(".. "):
            pending = indent
        table_row = stripped.startswith("|") and stripped.endswith("|") and len(stripped) > 1
        border = stripped.startswith("+") and set(stripped) <= set("+-=")
        if table_row or border or stripped.startswith(("| ", ".. ")):
            out.append(line)
            continue
        parts = _LITERAL.split(line)
        out.append("".join(p if i % 2 else p.replace("|", "\\|") for i, p in enumerate(parts)))
    return out
