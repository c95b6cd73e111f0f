"""The package's shape: imports run downhill (ndrql._layers), no cycles, lazy imports say why, short modules.

The checks walk the source with ``tools/import_graph.py`` (``ast``, nothing imported); every import
counts, at module top or inside a function.
"""

from __future__ import annotations

import ast
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

from ndrql._layers import LAYERS, layer_line

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "import_graph.py"


def _load_tool():
    spec = importlib.util.spec_from_file_location("import_graph", TOOL)
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("import_graph", module)
    spec.loader.exec_module(module)
    return module


G = _load_tool()
IMPORTS = G.scan()


def _lines(items) -> str:
    return "\n".join(G._where(i) for i in items)


def test_every_package_has_a_layer():
    assert G.unlisted_packages() == [], "add the package to a layer in src/ndrql/_layers.py"


def test_no_upward_or_sideways_import():
    bad = G.upward(IMPORTS)
    assert not bad, f"imports against the layering ({layer_line()}):\n{_lines(bad)}"


def test_no_cycle_between_packages():
    assert G.cycles(G.graph(IMPORTS, G.package_of)) == []


def test_no_cycle_between_modules():
    assert G.cycles(G.graph(IMPORTS)) == [], "modules import each other (inside a package too)"


def test_lazy_imports_say_why():
    bad = G.unmarked_lazy(IMPORTS)
    assert not bad, f"move these imports to the module top, or add '# lazy: <reason>':\n{_lines(bad)}"


def test_lazy_imports_are_few():
    lazy = [i for i in IMPORTS if i.lazy]
    assert len(lazy) < len(IMPORTS) / 5, f"{len(lazy)} of {len(IMPORTS)} ndrql imports are inside functions"


def test_no_module_over_400_lines():
    long = G.long_modules()
    assert long == [], f"modules over {G.MAX_MODULE_LINES} lines: {long}"


def _definitions() -> dict[str, list[str]]:
    """Function and class docstrings that open with ``Eq. N`` or ``Q-update``: where each equation is defined."""
    out: dict[str, list[str]] = {}
    for module, path in G.module_names().items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                m = re.match(r"(Eq\. \d+|Q-update)\b", ast.get_docstring(node) or "")
                if m:
                    out.setdefault(m.group(1), []).append(f"{module}.{node.name}")
    return out


def test_each_equation_is_defined_once():
    """Eqs. 1-7 of the paper and the Q-update: one docstring each defines it, the others cite it."""
    found = _definitions()
    assert sorted(found) == [f"Eq. {n}" for n in range(1, 8)] + ["Q-update"], found
    assert all(len(v) == 1 for v in found.values()), {k: v for k, v in found.items() if len(v) > 1}
    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    for name, (where,) in found.items():
        assert f"`{where.removeprefix('ndrql.')}`" in doc, f"docs/architecture.md: say where {name} lives ({where})"


def test_the_checks_catch_what_they_look_for(tmp_path):
    """A made-up package with one of each problem: the tool finds each one, and nothing else."""
    files = {
        "__init__.py": "",
        "maps/__init__.py": "",
        "maps/grid.py": "from ndrql.planning.runner import run_plan\n",  # maps is below planning
        "maps/area.py": "def f():\n    from ndrql.maps import grid\n",  # lazy without a reason
        "maps/safe.py": "def f():\n    from ndrql.maps import grid  # lazy: loads numba\n",
        "planning/__init__.py": "",
        "planning/runner.py": "import ndrql.planning.rules\n",
        "planning/rules.py": "def f():\n    import ndrql.planning.runner  # lazy: a cycle all the same\n",
        "planning/kernel.py": "import importlib\nimportlib.import_module('ndrql.maps.safe')\n",
    }
    for name, text in files.items():
        path = tmp_path / "ndrql" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    imports = G.scan(tmp_path)
    assert {(i.source, i.target) for i in G.upward(imports)} == {("ndrql.maps.grid", "ndrql.planning.runner")}
    assert G.cycles(G.graph(imports)) == [["ndrql.planning.rules", "ndrql.planning.runner"]]
    assert G.cycles(G.graph(imports, G.package_of)) == [["maps", "planning"]]
    assert [(i.source, i.line) for i in G.unmarked_lazy(imports)] == [("ndrql.maps.area", 2)]
    assert ("ndrql.planning.kernel", "ndrql.maps.safe") in {(i.source, i.target) for i in imports}
    long = G.long_modules(tmp_path, limit=1)
    assert ("ndrql.planning.kernel", 2) in long and all(n == 2 for _, n in long)


def test_tool_prints_the_graph_and_writes_dot(tmp_path):
    dot = tmp_path / "graph.dot"
    r = subprocess.run([sys.executable, str(TOOL), "--dot", str(dot)], capture_output=True, text=True, timeout=120)
    assert f"layers: {layer_line()}" in r.stdout
    assert "  api: " in r.stdout and "upward or sideways imports: 0" in r.stdout
    text = dot.read_text()
    assert text.startswith("digraph ndrql {") and '"api" -> "pipeline";' in text and "color=red" not in text
    assert r.returncode == (1 if G.long_modules() else 0), r.stdout[-2000:]


def test_docs_state_the_layering():
    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert layer_line() in doc, "docs/architecture.md: paste the layer line of tools/import_graph.py"
    for group in LAYERS:
        for package in group:
            if package not in ("ndrql", "__main__", "_layers", "version"):
                assert f"`{package}`" in doc, f"docs/architecture.md does not describe {package}"


def test_the_docs_graph_is_the_codes():
    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert G.doc_block(IMPORTS) in doc, ("docs/architecture.md's import graph has drifted from the code: "
                                         "run python tools/import_graph.py --write-doc")
    assert G.doc_with_graph(doc, IMPORTS) == doc


def _imported_modules(path: Path) -> set[str]:
    """Top-level names of every module ``path`` imports (absolute imports, at any depth of the file)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module.split(".")[0])
    return out


def test_scripts_do_not_import_the_tests():
    """Scripts in ``tools/``, ``benchmarks/``, ``studies/`` and ``examples/`` stand on the package alone:
    nothing from ``tests/`` (its ``helpers``) and no ``sys.path`` edit to reach it. Maps the tests and a
    script share live in the package (``ndrql.synth.drawn``)."""
    scripts = [p for d in ("tools", "benchmarks", "studies", "examples") for p in (ROOT / d).rglob("*.py")]
    assert scripts
    bad = [str(p.relative_to(ROOT)) for p in scripts
           if {"helpers", "tests", "conftest"} & _imported_modules(p) or '/ "tests"' in p.read_text()]
    assert not bad, f"these scripts reach into tests/: {bad}"
