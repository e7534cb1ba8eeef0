"""The viewer's ES modules (app/static/viewer/*.js) import each other without a cycle, and share
mutable state only through state.js.

The imports are read from the source (static `import ... from "./x.js"` and `export ... from`),
and the cycles are the strongly connected components of that graph: there must be none. A module
exports no `let` (or `var`) binding: what several modules change (the model shown, its sliders,
poses, size, load token) is a field of state.js's `current` object, and state.js imports nothing,
so no circle can run through it."""

from __future__ import annotations

import re

from tests.paths import REPO

VIEWER = REPO / "app" / "static" / "viewer"
IMPORT = re.compile(r"""^\s*(?:import|export)\b[^;]*?\bfrom\s*["']\./([\w.-]+\.js)["']|^\s*import\s*["']\./([\w.-]+\.js)["']""",
                    re.MULTILINE)
#: `export let x`, `export var x, y`: a binding other modules would see change
EXPORTED_MUTABLE = re.compile(r"^\s*export\s+(?:let|var)\b", re.MULTILINE)
#: `export { a, b as c }` (a list naming local bindings) and the module's own `let` / `var` names
EXPORT_LIST = re.compile(r"^\s*export\s*\{([^}]*)\}\s*(?:;|$)", re.MULTILINE)
MUTABLE_DECLARATION = re.compile(r"^\s*(?:let|var)\s+([\w$]+)", re.MULTILINE)


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


def test_no_import_cycle():
    found = [sorted(c) for c in cycles(imports())]
    assert found == [], f"import cycles among the viewer's modules: {found}"


def mutable_exports(source: str) -> list[str]:
    """The `let` / `var` bindings a module's source exports (by declaration or in an export list)."""
    found = [m.group(0).strip() for m in EXPORTED_MUTABLE.finditer(source)]
    mutable = set(MUTABLE_DECLARATION.findall(source))
    for names in EXPORT_LIST.findall(source):
        for name in names.split(","):
            local = name.split(" as ")[0].strip()
            if local in mutable:
                found.append(local)
    return found


def test_the_mutable_export_finder_finds_them():
    assert mutable_exports("export let a = 1;\nexport const b = 2;\n") == ["export let"]
    assert mutable_exports("let a = 1;\nconst b = 2;\nexport { a as c, b };\n") == ["a"]
    assert mutable_exports("let a = 1;\nexport const current = { a };\nexport function f() { a += 1; }\n") == []


def test_no_module_exports_a_mutable_binding():
    found = {path.name: names for path in sorted(VIEWER.glob("*.js")) if (names := mutable_exports(path.read_text()))}
    assert found == {}, f"modules exporting let/var bindings (share them through state.js instead): {found}"


def test_the_shared_state_imports_no_module():
    assert imports()["state.js"] == set()
