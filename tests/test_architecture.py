"""The layer rule and the absence of import circles, read from the import graph.

Layers (docs/architecture.md), lowest first; a module never imports a module of
a higher layer, and peers of one layer import each other only where
``PEER_IMPORTS`` allows it::

    0 blocks (and ctrlblocks._lazy, the packages' lazy re-exports, and
      ctrlblocks.compiled, the loader of the optional compiled blocks)
    1 plants, tuning, testing
    2 loops
    3 sim, runtime, fast, plc
    4 web, cli (ctrlblocks.cli and every sub-command module ``*.cli`` / ``__main__``)

Every import counts, also one inside a function (a lazy import is still a
dependency); imports under ``if TYPE_CHECKING:`` do not.
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "ctrlblocks"

LAYERS: dict[str, int] = {
    "": 0,  # the package's __init__: re-exports the blocks
    "_lazy": 0,  # the packages' lazy re-exports (PEP 562; standard library only)
    "compiled": 0,  # the loader of the optional compiled blocks (standard library only)
    "blocks": 0,
    "plants": 1,
    "tuning": 1,
    "testing": 1,  # the fuzz campaign of the block contract, for any block (imports blocks)
    "loops": 2,
    "health": 2,  # loop performance assessment: data -> figures and findings (numpy, tuning)
    "sim": 3,
    "runtime": 3,
    "fast": 3,
    "plc": 3,
    "web": 4,
    "cli": 4,
}
CLI_LAYER = 4

#: Allowed imports between peers of one layer (importer's area -> imported area).
PEER_IMPORTS: set[tuple[str, str]] = {
    ("tuning", "plants"),  # tuning experiments (bump tests) run on process models
    ("", "blocks"),  # the package's __init__ re-exports the blocks
    ("blocks", "compiled"),  # the blocks load their compiled build, if any, first
    ("cli", "web"),  # ``ctrlblocks web`` starts the faceplate
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST, package: str) -> set[str]:
    """Every ``ctrlblocks`` name imported by a module (resolved, not yet trimmed)."""
    out: set[str] = set()
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and _is_type_checking(node):
            stack.extend(node.orelse)
            continue
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            out.add(target)
            out.update(f"{target}.{a.name}" for a in node.names)
        stack.extend(ast.iter_child_nodes(node))
    return {n for n in out if n == "ctrlblocks" or n.startswith("ctrlblocks.")}


def import_graph() -> dict[str, set[str]]:
    """``module -> modules it imports`` over ``src/ctrlblocks`` (names trimmed to modules)."""
    files = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for mod, path in files.items():
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        targets = set()
        for name in _imports(ast.parse(path.read_text(encoding="utf-8")), package):
            while name not in files:  # ``from x import attr``: the module is x
                name = name.rpartition(".")[0]
            if name != mod:
                targets.add(name)
        graph[mod] = targets
    return graph


def area(mod: str) -> str:
    """The layer area of a module: its sub-package, or ``cli`` for a command module."""
    parts = mod.split(".")[1:]
    if parts and parts[-1] in ("cli", "__main__"):
        return "cli"
    return parts[0] if parts else ""


def layer_violations(graph: dict[str, set[str]]) -> set[tuple[str, str]]:
    bad = set()
    for mod, targets in graph.items():
        a = area(mod)
        for t in targets:
            b = area(t)
            if a == b or (a, b) in PEER_IMPORTS or LAYERS[b] < LAYERS[a]:
                continue
            bad.add((mod, t))
    return bad


def circles(graph: dict[str, set[str]]) -> list[set[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[set[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(comp)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


GRAPH = import_graph()


def test_every_subpackage_has_a_layer():
    assert {area(m) for m in GRAPH} <= set(LAYERS), "add the new sub-package to LAYERS"


def test_graph_sees_lazy_and_relative_imports():
    # a check of the reader itself: sim.scenario imports sim.metrics at module level
    assert "ctrlblocks.sim.metrics" in GRAPH["ctrlblocks.sim.scenario"]
    assert "ctrlblocks.blocks.base" in GRAPH["ctrlblocks.plants.linear"]


def test_no_lower_layer_imports_a_higher_one():
    bad = layer_violations(GRAPH)
    assert not bad, f"layer rule broken (see docs/architecture.md): {sorted(bad)}"


def test_layer_check_catches_an_upward_import():
    graph = {"ctrlblocks.runtime.loop": {"ctrlblocks.sim.scenario", "ctrlblocks.loops.spec"}}
    assert layer_violations(graph) == {("ctrlblocks.runtime.loop", "ctrlblocks.sim.scenario")}
    assert layer_violations({"ctrlblocks.blocks.pid": {"ctrlblocks.loops.spec"}}) != set()


#: Peers that must never import each other, whatever else changes (issue 31): the
#: simulator finds the compiled lane as an installed plugin (``ctrlblocks.loops.lane``,
#: entry point group ``ctrlblocks.lanes``), and the sweeps of scenarios live in ``sim``.
FORBIDDEN: set[tuple[str, str]] = {("sim", "fast"), ("fast", "sim")}


def test_sim_and_fast_import_nothing_of_each_other():
    bad = sorted((m, t) for m, ts in GRAPH.items() for t in ts if (area(m), area(t)) in FORBIDDEN)
    assert bad == [], f"sim <-> fast (see docs/architecture.md): {bad}"
    assert not FORBIDDEN & PEER_IMPORTS


def test_the_forbidden_pairs_are_caught_both_ways():
    for a, b in (("sim", "fast"), ("fast", "sim")):
        graph = {f"ctrlblocks.{a}.x": {f"ctrlblocks.{b}.y"}}
        assert layer_violations(graph) == {(f"ctrlblocks.{a}.x", f"ctrlblocks.{b}.y")}


def test_no_import_circles():
    assert circles(GRAPH) == [], "import circles between modules (see docs/architecture.md)"


def test_circle_finder_finds_a_circle_through_three_modules():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert circles(graph) == [{"a", "b", "c"}]


def test_no_layer_above_loops_branches_on_a_structure_name() -> None:
    # issue 17: a structure is described once, by its Structure object in
    # loops/structures.py; the simulator and the runtime ask it, never compare names
    import re

    pat = re.compile(r"""structure\s*(==|!=|in)\s*[("']""")
    hits = []
    for sub in ("sim", "runtime", "web", "fast", "plc"):
        for f in sorted((SRC / "ctrlblocks" / sub).rglob("*.py")):
            for n, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
                if pat.search(line):
                    hits.append(f"{f.relative_to(SRC)}:{n}: {line.strip()}")
    assert hits == []
