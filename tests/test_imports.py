"""The package's modules import one another without a circle: every import counts, at module
level, inside a function, or under ``TYPE_CHECKING`` (a circle hidden by any of these is still a
coupling both ways), read from the source with :mod:`ast`, so the test sees what a reader
sees and imports nothing."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "fmu_src" / "iceimpact"
ROOT = PACKAGE.name


def _module_names(package: Path) -> dict[str, Path]:
    """Every module of the package by its dotted name (a package by its ``__init__.py``)."""
    names = {}
    for path in sorted(package.rglob("*.py")):
        parts = (ROOT, *path.relative_to(package).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names[".".join(parts)] = path
    return names


def _absolute(module: str, is_package: bool, level: int, target: str | None) -> str:
    """The dotted name a relative import ``from <level dots><target> import ...`` in ``module``
    refers to (the name itself for an absolute one)."""
    if level == 0:
        return target or ""
    base = module.split(".")
    # a package's "." is the package itself, a module's is the package holding it
    base = base[:len(base) - level + (1 if is_package else 0)]
    return ".".join(base + ([target] if target else []))


def import_graph(package: Path = PACKAGE) -> dict[str, set[str]]:
    """Each module of the package and the package modules it imports: ``import a.b`` imports
    ``a.b``; ``from a import b`` imports the submodule ``a.b`` where there is one, else ``a``;
    relative imports resolved against the importing module."""
    modules = _module_names(package)
    graph: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                source = _absolute(name, is_package, node.level, node.module)
                for alias in node.names:
                    submodule = f"{source}.{alias.name}"
                    targets.append(submodule if submodule in modules else source)
            graph[name].update(t for t in targets if t in modules and t != name)
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One circle of imports (its modules, the first repeated at the end), or None: a depth-first
    search in a fixed order, so the same graph reports the same circle."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done (no circle through it)
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One circle per group of nodes that reach one another (each circle once, however many
    run through the group): a circle is found, its nodes grouped with every node that both
    reaches it and is reached from it, and the search goes on without the group."""
    graph = {node: set(targets) for node, targets in graph.items()}
    found = []
    while (cycle := find_cycle(graph)) is not None:
        found.append(cycle)
        group = _reaching(graph, cycle[0]) & _reaching(_reversed(graph), cycle[0])
        graph = {node: targets - group for node, targets in graph.items() if node not in group}
    return found


def _reaching(graph: dict[str, set[str]], start: str) -> set[str]:
    seen, todo = {start}, [start]
    while todo:
        for nxt in graph[todo.pop()]:
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    return seen


def _reversed(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    back: dict[str, set[str]] = {node: set() for node in graph}
    for node, targets in graph.items():
        for target in targets:
            back[target].add(node)
    return back


def _part(module: str, package: str) -> str | None:
    """The direct part of ``package`` (module or subpackage) that holds ``module``, or None."""
    prefix = package + "."
    if not module.startswith(prefix):
        return None
    return prefix + module[len(prefix):].split(".")[0]


def package_graph(graph: dict[str, set[str]], package: str) -> dict[str, set[str]]:
    """The imports among the direct parts of ``package`` (its modules, and its subpackages each
    taken whole): a circle here is two parts that need each other, even where no two modules
    import each other (``a.x`` imports ``b.y`` and ``b.z`` imports ``a.w``)."""
    parts: dict[str, set[str]] = {}
    for module, targets in graph.items():
        source = _part(module, package)
        if source is None:
            continue
        edges = parts.setdefault(source, set())
        for target in targets:
            target = _part(target, package)
            if target is not None and target != source:
                edges.add(target)
                parts.setdefault(target, set())
    return parts


def all_circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The circles among the modules, then among the parts of every package; a circle of parts
    that a circle already found runs through (that circle seen from the package) is not
    reported again."""
    packages = {".".join(module.split(".")[:i]) for module in graph
                for i in range(1, module.count(".") + 1)}  # (each module's enclosing ones)
    found = circles(graph)
    for package in sorted(packages):
        for cycle in circles(package_graph(graph, package)):
            seen_from_package = ({_part(node, package) for node in earlier} for earlier in found)
            if not any(set(cycle) <= parts for parts in seen_from_package):
                found.append(cycle)
    return found


def describe(cycle: list[str], graph: dict[str, set[str]]) -> str:
    """A circle as its steps, each step between parts of a package with one import that makes
    it (``a -> b (a.x imports b.y)``)."""
    def inside(module: str, part: str) -> bool:
        return module == part or module.startswith(part + ".")

    steps = []
    for source, target in zip(cycle, cycle[1:], strict=False):
        if target in graph.get(source, ()):
            steps.append(f"{source} -> {target}")
            continue
        module, imported = min((m, t) for m, targets in graph.items() if inside(m, source)
                               for t in targets if inside(t, target))
        steps.append(f"{source} -> {target} ({module} imports {imported})")
    return "\n    ".join(steps)


def test_the_graph_sees_every_kind_of_import(tmp_path):
    """The reader counts imports inside functions, under TYPE_CHECKING, relative ones and a
    submodule imported by name from its package."""
    pkg = tmp_path / ROOT
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from typing import TYPE_CHECKING\n"
                              "if TYPE_CHECKING:\n    from .sub import b\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "b.py").write_text("def f():\n    from .. import c\n")
    (pkg / "c.py").write_text(f"import {ROOT}.a\nfrom . import sub\n")
    graph = import_graph(pkg)
    assert graph[f"{ROOT}.a"] == {f"{ROOT}.sub.b"}
    assert graph[f"{ROOT}.sub.b"] == {f"{ROOT}.c"}
    assert graph[f"{ROOT}.c"] == {f"{ROOT}.a", f"{ROOT}.sub"}
    assert all_circles(graph) == [[f"{ROOT}.a", f"{ROOT}.sub.b", f"{ROOT}.c", f"{ROOT}.a"]]


def test_a_circle_between_packages_is_seen():
    """Two subpackages that need each other make a circle even when no module is on it twice;
    each circle is reported once."""
    graph = {"p.a.x": {"p.b.y"}, "p.b.y": set(), "p.b.z": {"p.a.w"}, "p.a.w": set(),
             "p.c": {"p.d"}, "p.d": {"p.c"}}
    assert all_circles(graph) == [["p.c", "p.d", "p.c"], ["p.a", "p.b", "p.a"]]


def test_no_import_circle():
    """No module of the package imports, through any chain of imports, itself, and no two parts
    of a package (modules, subpackages) need each other."""
    graph = import_graph()
    found = all_circles(graph)
    assert not found, "import circles:\n" + "\n".join(
        "  circle:\n    " + describe(cycle, graph) for cycle in found)
