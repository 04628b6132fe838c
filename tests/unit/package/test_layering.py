"""The package's layering (docs/architecture.md): no import circle, imports go downward only,
io/viz/analysis depend on core only, no private name used across packages."""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[3] / "src"
PKG = SRC / "erosim"

# a package may import those of lower rank, itself, and (rank 2, the physics) its peers
RANK = {
    "core": 0, "data": 1, "kernels": 1, "io": 1, "viz": 1, "analysis": 1,
    "sph": 2, "terrain": 2, "erosion": 2, "hydrology": 2,
    "coupling": 3, "simulation": 4, "scenarios": 5, "validation": 6, "api": 6, "view": 6,
    "sweep": 7, "tiles": 8, "bench": 8, "cli": 9, "__main__": 10,
}  # fmt: skip
CORE_ONLY = {"io", "viz", "analysis", "data", "kernels"}
ALSO = {"analysis": {"kernels"}}  # measurements interpolate with the SPH kernels


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _resolve(name: str) -> str | None:
    """The erosim module a dotted name refers to (a module, a package, or an attribute of one)."""
    parts = name.split(".")
    while parts:
        p = SRC.joinpath(*parts)
        if p.with_suffix(".py").is_file() or (p / "__init__.py").is_file():
            return ".".join(parts)
        parts = parts[:-1]
    return None


def _package(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "erosim"


def _imports(path: Path):
    """(imported module, names imported from it, aliases bound to modules) of one file, lazy imports too."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    edges, private, aliases = [], [], {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("erosim"):
                    mod = _resolve(a.name)
                    edges.append(mod)
                    aliases[a.asname or a.name.split(".")[0]] = mod
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("erosim"):
            for a in node.names:
                sub = _resolve(f"{node.module}.{a.name}")
                target = sub if sub and sub.endswith(a.name) else _resolve(node.module)
                edges.append(target)
                if sub and sub.endswith(a.name):
                    aliases[a.asname or a.name] = sub
                elif a.name.startswith("_") and not a.name.startswith("__"):
                    private.append((target, a.name))
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            private.append((aliases[node.value.id], node.attr))
    return [e for e in edges if e], private


def _graph():
    graph, private = {}, {}
    for path in sorted(PKG.rglob("*.py")):
        mod = _module_name(path)
        edges, priv = _imports(path)
        graph[mod] = sorted(set(edges) - {mod})
        private[mod] = priv
    return graph, private


def _cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_circle():
    graph, _ = _graph()
    assert len(graph) > 60
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_a_circle():
    assert _cycles({"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}) == [["a", "b", "c"]]


def test_imports_go_downward_only():
    graph, _ = _graph()
    wrong = []
    for mod, targets in graph.items():
        p = _package(mod)
        for t in targets:
            q = _package(t)
            if q in (p, "erosim") or p == "erosim":
                continue
            if p in CORE_ONLY:
                ok = q == "core" or q in ALSO.get(p, ())
            else:
                ok = RANK[q] < RANK[p] or (RANK[q] == RANK[p] == 2)
            if not ok:
                wrong.append(f"{mod} -> {t}")
    assert wrong == []


def test_no_private_name_across_packages():
    _, private = _graph()
    wrong = [
        f"{mod} uses {t}.{name}" for mod, items in private.items() for t, name in items if _package(t) != _package(mod)
    ]
    assert wrong == []


@pytest.mark.parametrize("source, expect", [("erosim.sph.solver", "sph"), ("erosim.cli", "cli"), ("erosim", "erosim")])
def test_package_of(source, expect):
    assert _package(source) == expect
