#!/usr/bin/env python3
"""ndrql's import graph, drawn from the code, and every import that breaks the layering.

    .venv/bin/python tools/import_graph.py                 # package graph, upward imports, cycles
    .venv/bin/python tools/import_graph.py --modules       # ... and the module graph
    .venv/bin/python tools/import_graph.py --dot graph.dot # Graphviz text of the package graph
    .venv/bin/python tools/import_graph.py --write-doc     # refresh the graph in docs/architecture.md

Walks ``src/ndrql`` with :mod:`ast` (nothing is imported but :mod:`ndrql._layers`, the one home of
the layering). Every ``import``/``from ... import`` of an ``ndrql`` module counts, at module top or
inside a function, and so does ``importlib.import_module("ndrql...")``. Exit status 1 when an import
goes up or sideways, a cycle exists (between packages or between modules) or an ``ndrql`` import
inside a function lacks its ``# lazy: <reason>`` comment.
"""

from __future__ import annotations

import argparse
import ast
import sys
from dataclasses import dataclass
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
sys.path.insert(0, str(SRC))

from ndrql._layers import LAYERS, LAZY_MARK, MAX_MODULE_LINES, layer_line, layer_of  # noqa: E402

ROOT = "ndrql"


@dataclass(frozen=True)
class Import:
    """One import of an ``ndrql`` module by another."""

    source: str
    """Importing module, dotted (``ndrql.maps.grid``)."""
    target: str
    """Imported module, dotted."""
    path: Path
    line: int
    lazy: bool
    """Inside a function (runs on call, not on import)."""
    marked: bool
    """Carries a ``# lazy: <reason>`` comment (on its lines or the line above)."""


def package_of(module: str) -> str:
    """``ndrql.maps.grid`` -> ``maps``; ``ndrql.io`` -> ``io``; ``ndrql`` -> ``ndrql``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def module_names(src: Path = SRC) -> dict[str, Path]:
    """Every module of the package, dotted name -> file."""
    out = {}
    for path in sorted((src / ROOT).rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def extension_names(src: Path = SRC) -> dict[str, Path]:
    """C extension modules of the package, dotted name -> C source (``src/ndrql/maps/_kernels.c`` ->
    ``ndrql.maps._kernels``, built by setup.py). An import of one ends there: it imports nothing of ndrql."""
    return {".".join(path.relative_to(src).with_suffix("").parts): path for path in sorted((src / ROOT).rglob("*.c"))}


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The longest prefix of ``name`` that is a module of the package."""
    parts = name.split(".")
    while parts:
        dotted = ".".join(parts)
        if dotted in modules:
            return dotted
        parts.pop()
    return None


def _targets(node: ast.AST, module: str, is_pkg: bool, modules: dict[str, Path]) -> list[str]:
    """The ``ndrql`` modules an import node (or ``importlib.import_module`` call) loads."""
    names: list[str] = []
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    elif isinstance(node, ast.ImportFrom):
        base = node.module or ""
        if node.level:
            here = module.split(".") if is_pkg else module.split(".")[:-1]
            here = here[: len(here) - (node.level - 1)]
            base = ".".join(here + ([base] if base else []))
        names = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
    elif isinstance(node, ast.Call):
        arg = node.args[0] if node.args else None
        if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
            names = [arg.value]
        elif isinstance(arg, ast.JoinedStr) and arg.values and isinstance(arg.values[0], ast.Constant):
            names = [str(arg.values[0].value).rstrip(".")]  # f"ndrql.cli.{name}": the package it names
    out = []
    for name in names:
        if name == ROOT or name.startswith(ROOT + "."):
            target = _resolve(name, modules)
            if target is not None and target != module:
                out.append(target)
    return out


def _is_import_module(node: ast.AST) -> bool:
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    return (isinstance(f, ast.Attribute) and f.attr == "import_module") or (
        isinstance(f, ast.Name) and f.id in ("import_module", "__import__"))


def scan_module(module: str, path: Path, modules: dict[str, Path]) -> list[Import]:
    """The ``ndrql`` imports of one module."""
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    tree = ast.parse(text, str(path))
    is_pkg = path.name == "__init__.py"
    found: list[Import] = []

    def visit(node: ast.AST, in_function: bool) -> None:
        if isinstance(node, (ast.Import, ast.ImportFrom)) or _is_import_module(node):
            first, last = node.lineno, getattr(node, "end_lineno", node.lineno) or node.lineno
            span = lines[max(0, first - 2): last]
            marked = any(LAZY_MARK in s for s in span)
            for target in dict.fromkeys(_targets(node, module, is_pkg, modules)):
                found.append(Import(module, target, path, first, in_function, marked))
        inner = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        for child in ast.iter_child_nodes(node):
            visit(child, inner)

    visit(tree, False)
    return found


def scan(src: Path = SRC) -> list[Import]:
    """Every ``ndrql`` import in the package."""
    modules = module_names(src)
    known = {**modules, **extension_names(src)}
    return [imp for module, path in modules.items() for imp in scan_module(module, path, known)]


def graph(imports: list[Import], key=lambda m: m) -> dict[str, set[str]]:
    """Adjacency sets, nodes named by ``key`` (identity: modules; :func:`package_of`: packages)."""
    out: dict[str, set[str]] = {}
    for imp in imports:
        a, b = key(imp.source), key(imp.target)
        out.setdefault(a, set())
        out.setdefault(b, set())
        if a != b:
            out[a].add(b)
    return out


def cycles(adjacency: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def strong(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(adjacency.get(v, ())):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(max(10000, sys.getrecursionlimit()))
    for v in sorted(adjacency):
        if v not in index:
            strong(v)
    return sorted(out)


def upward(imports: list[Import]) -> list[Import]:
    """Imports of a package on the same or a later layer (another package than the importer's)."""
    out = []
    for imp in imports:
        a, b = package_of(imp.source), package_of(imp.target)
        if a != b and layer_of(b) >= layer_of(a):
            out.append(imp)
    return out


def unmarked_lazy(imports: list[Import]) -> list[Import]:
    """``ndrql`` imports inside functions without a ``# lazy: <reason>`` comment."""
    return [imp for imp in imports if imp.lazy and not imp.marked]


def unlisted_packages(src: Path = SRC) -> list[str]:
    """Packages of the code that :data:`LAYERS` does not place."""
    listed = {p for group in LAYERS for p in group}
    return sorted({package_of(m) for m in module_names(src)} - listed)


def long_modules(src: Path = SRC, limit: int = MAX_MODULE_LINES) -> list[tuple[str, int]]:
    """Modules over ``limit`` lines, with their length."""
    out = []
    for module, path in module_names(src).items():
        n = len(path.read_text(encoding="utf-8").splitlines())
        if n > limit:
            out.append((module, n))
    return out


def _where(imp: Import) -> str:
    rel = imp.path.relative_to(SRC.parent) if imp.path.is_relative_to(SRC.parent) else imp.path
    return f"{rel}:{imp.line}: {imp.source} -> {imp.target}{' (in a function)' if imp.lazy else ''}"


def to_dot(adjacency: dict[str, set[str]]) -> str:
    """Graphviz text of a package graph, one rank per layer, bottom layer at the bottom."""
    lines = ["digraph ndrql {", "  rankdir=BT;", "  node [shape=box, fontname=Helvetica];"]
    for i, group in enumerate(LAYERS):
        present = [p for p in group if p in adjacency]
        if present:
            lines.append(f"  {{ rank=same; // layer {i}")
            lines += [f'    "{p}";' for p in present]
            lines.append("  }")
    for a in sorted(adjacency):
        for b in sorted(adjacency[a]):
            bad = ' [color=red, penwidth=2]' if layer_of(b) >= layer_of(a) else ""
            lines.append(f'  "{a}" -> "{b}"{bad};')
    lines.append("}")
    return "\n".join(lines) + "\n"


#: The document whose package graph is generated by :func:`package_lines` (between the two marks).
DOC = SRC.parent / "docs" / "architecture.md"
DOC_BEGIN = "<!-- import graph: generated by tools/import_graph.py --write-doc; do not edit -->"
DOC_END = "<!-- end of import graph -->"


def package_lines(imports: list[Import]) -> list[str]:
    """Each package and the packages it imports, in layer order (the doc's graph and the report's)."""
    out = ["package imports (importer: imported packages, lower layers only):"]
    pkg = graph(imports, package_of)
    for p in [p for group in LAYERS for p in group if p in pkg]:
        out.append(f"  {p}: {', '.join(sorted(pkg[p], key=lambda q: (layer_of(q), q))) or '-'}")
    return out


def doc_block(imports: list[Import]) -> str:
    """The generated part of :data:`DOC`: the marks around a fenced block of :func:`package_lines`."""
    return "\n".join([DOC_BEGIN, "```", *package_lines(imports), "```", DOC_END])


def doc_with_graph(text: str, imports: list[Import]) -> str:
    """``text`` (the doc) with its generated block replaced by the current graph; ``ValueError`` without the marks."""
    head, sep, rest = text.partition(DOC_BEGIN)
    _, sep2, tail = rest.partition(DOC_END)
    if not sep or not sep2:
        raise ValueError(f"{DOC.name} has no '{DOC_BEGIN}' ... '{DOC_END}' block")
    return head + doc_block(imports) + tail


def report(imports: list[Import], modules: bool = False) -> tuple[str, int]:
    """The text the tool prints, and the number of problems in it."""
    out = [f"layers: {layer_line()}", "", *package_lines(imports)]
    pkg = graph(imports, package_of)
    if modules:
        out += ["", "module imports:"]
        mod = graph(imports)
        out += [f"  {m}: {', '.join(sorted(mod[m])) or '-'}" for m in sorted(mod)]
    problems = 0
    sections = [
        ("packages not in ndrql._layers.LAYERS", unlisted_packages()),
        ("upward or sideways imports", [_where(i) for i in upward(imports)]),
        ("package cycles", [" <-> ".join(c) for c in cycles(pkg)]),
        ("module cycles", [" <-> ".join(c) for c in cycles(graph(imports))]),
        (f"ndrql imports inside functions without '{LAZY_MARK} <reason>'", [_where(i) for i in unmarked_lazy(imports)]),
        (f"modules over {MAX_MODULE_LINES} lines", [f"{m}: {n}" for m, n in long_modules()]),
    ]
    for title, items in sections:
        out += ["", f"{title}: {len(items)}"]
        out += [f"  {s}" for s in items]
        problems += len(items)
    lazy = [i for i in imports if i.lazy]
    out += ["", f"ndrql imports: {len(imports)} ({len(imports) - len(lazy)} at module top, {len(lazy)} inside functions)"]
    return "\n".join(out) + "\n", problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dot", metavar="FILE", help="write the package graph as Graphviz text")
    parser.add_argument("--modules", action="store_true", help="also print the module graph")
    parser.add_argument("--write-doc", action="store_true", help=f"write the package graph into {DOC.name}")
    args = parser.parse_args(argv)
    imports = scan()
    if args.write_doc:
        DOC.write_text(doc_with_graph(DOC.read_text(encoding="utf-8"), imports), encoding="utf-8")
    text, problems = report(imports, args.modules)
    sys.stdout.write(text)
    if args.dot:
        Path(args.dot).write_text(to_dot(graph(imports, package_of)), encoding="utf-8")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
