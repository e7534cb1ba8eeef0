"""A griffe extension for the API reference: the library's docstrings are written for ``help()``
and Sphinx-style roles; this renders them as Markdown without changing them.

- a paragraph ending in ``::`` and the indented block after it become a fenced code block;
- doctest blocks (``>>>`` lines and their output) become fenced ``pycon`` blocks;
- roles ``:func:`~a.b.c```, ``:class:`x```, ``:mod:`...``` become inline code (``c`` / ``x``);
- reST literals ````x```` become Markdown code ```x```.
"""

from __future__ import annotations

import re

import griffe

ROLE = re.compile(r":(?:func|class|mod|meth|attr|data|exc|obj):`~?([^`]+)`")
TILDE = re.compile(r":(?:func|class|mod|meth|attr|data|exc|obj):`~([^`]+)`")
DOUBLE = re.compile(r"``([^`]+)``")


def _role(match: re.Match) -> str:
    return f"`{match.group(1)}`"


def _short(match: re.Match) -> str:
    return f"`{match.group(1).rsplit('.', 1)[-1]}`"


def markdown(text: str) -> str:
    lines = text.splitlines()
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        stripped = line.strip()
        if stripped.startswith(">>>"):
            indent = len(line) - len(line.lstrip())
            block = []
            while i < len(lines) and lines[i].strip():
                block.append(lines[i][indent:] if len(lines[i]) >= indent else lines[i].lstrip())
                i += 1
            out += ["```pycon", *block, "```"]
            continue
        if stripped.endswith("::") and not stripped.startswith(".."):
            head = line.rstrip()[:-1] if not stripped == "::" else ""
            out.append(_inline(head.rstrip(":") + ":" if head.strip() else ""))
            i += 1
            while i < len(lines) and not lines[i].strip():
                i += 1
            block = []
            base = None
            while i < len(lines) and (not lines[i].strip() or base is None
                                      or len(lines[i]) - len(lines[i].lstrip()) >= base):
                if lines[i].strip() and base is None:
                    base = len(lines[i]) - len(lines[i].lstrip())
                block.append(lines[i][base:] if lines[i].strip() else "")
                i += 1
            while block and not block[-1]:
                block.pop()
            language = "pycon" if block and block[0].startswith(">>>") else "python"
            out += ["", "```" + language, *block, "```", ""]
            continue
        out.append(_inline(line))
        i += 1
    return "\n".join(out)


def _inline(line: str) -> str:
    line = TILDE.sub(_short, line)
    line = ROLE.sub(_role, line)
    return DOUBLE.sub(r"`\1`", line)


class RestructuredDocstrings(griffe.Extension):
    """Rewrites every docstring once it is loaded (see the module)."""

    def on_instance(self, *, obj: griffe.Object, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = markdown(obj.docstring.value)
