"""The viewer's ES modules (app/static/viewer/*.js) import each other without new cycles.

The imports are read from the source (static `import ... from "./x.js"` and `export ... from`),
and the cycles are the strongly connected components of that graph. One circle remains from
before (the model state of robot.js shared with the IK, ghost, path, velocity and workspace
modules): it is listed here so that it can only shrink; any other cycle, or that one grown,
fails. The loader / closed-forms circle is gone (the link <select> is link-options.js)."""

from __future__ import annotations

import re

from tests.paths import REPO

VIEWER = REPO / "app" / "static" / "viewer"
IMPORT = re.compile(r"""^\s*(?:import|export)\b[^;]*?\bfrom\s*["']\./([\w.-]+\.js)["']|^\s*import\s*["']\./([\w.-]+\.js)["']""",
                    re.MULTILINE)
#: the one circle left: its modules share robot.js's exported mutable bindings (to be removed, never grown)
KNOWN_CIRCLE = frozenset({"robot.js", "ik.js", "ghosts.js", "path.js", "velocity.js", "workspace.js"})


def imports() -> dict[str, set[str]]:
    graph = {}
    for path in sorted(VIEWER.glob("*.js")):
        graph[path.name] = {a or b for a, b in IMPORT.findall(path.read_text())}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[frozenset[str]]:
    """The strongly connected components of more than one module, or of one importing itself (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1 or v in graph.get(v, ()):
                out.append(frozenset(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_the_parser_finds_the_imports():
    graph = imports()
    assert "loader.js" in graph["viewer.js"] and "defaults.js" in graph["loader.js"]
    assert graph["defaults.js"] == set()  # no page, no three.js: node runs it
    assert all((VIEWER / name).exists() for targets in graph.values() for name in targets)


def test_the_cycle_finder_finds_a_cycle():
    assert cycles({"a.js": {"b.js"}, "b.js": {"c.js"}, "c.js": {"a.js"}, "d.js": {"a.js"}}) == [
        frozenset({"a.js", "b.js", "c.js"})]
    assert cycles({"a.js": {"b.js"}, "b.js": set()}) == []


def test_no_new_import_cycle():
    found = cycles(imports())
    other = [sorted(c) for c in found if not c <= KNOWN_CIRCLE]
    assert other == [], f"import cycles among the viewer's modules: {other}"
