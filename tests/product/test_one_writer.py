"""One writer (ndrql.io.atomic): every output of every subcommand refuses a planted symlink, a hard link
to an input and the package's own files, in process and before any work; and no module of src/ writes a
file any other way (the completeness scan fails for a new write call that bypasses the writer)."""

from __future__ import annotations

import argparse
import ast
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ndrql.cli import build_parser, main
from ndrql.cli.outputs import FILE_OUTPUTS, FOLDER_NAMES, OUT_IS_FILE
from ndrql.io.readset import PACKAGE_ROOT

SRC = Path(__file__).resolve().parents[2] / "src" / "ndrql"


def _leaves(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()):
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield prefix, parser
        return
    for name, sub in subs[0].choices.items():
        yield from _leaves(sub, prefix + (name,))


def _output_actions(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions if a.dest in FILE_OUTPUTS or a.dest in ("out", "run_dir")]


CASES = [(cmd, action.dest) for cmd, parser in _leaves(build_parser()) for action in _output_actions(parser)]


@pytest.fixture()
def work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("NDRQL_CACHE", str(tmp_path / "cache"))
    Image.fromarray(np.full((12, 12), 255, np.uint8)).save(tmp_path / "map.png")
    (tmp_path / "victim.bin").write_bytes(b"precious")
    (tmp_path / "ck.pt").write_bytes(b"not a checkpoint")
    (tmp_path / "set").mkdir()
    return tmp_path


def _argv(cmd: tuple[str, ...], dest: str, value: str) -> list[str]:
    """The least argv that parses, with ``value`` for the output ``dest`` (the guard runs before the command)."""
    parser = dict(_leaves(build_parser()))[cmd]
    argv = list(cmd)
    for action in parser._actions:
        if action.dest == dest:
            argv += [value] if not action.option_strings else [action.option_strings[-1], value]
        elif not action.option_strings and (action.nargs not in ("?", "*") or action.dest == "map"):
            argv.append({"map": "map.png", "set": "set", "target": "table1", "checkpoint": "ck.pt",
                         "weights": "ck.pt", "output": "other.png"}.get(action.dest, "x"))
        elif action.required:
            argv += [action.option_strings[-1], {"count": "1", "out": "outdir"}.get(action.dest, "x")]
    return argv


def _run(argv: list[str], capsys) -> tuple[int, str]:
    code = main(argv)
    return code, capsys.readouterr().err


def _is_folder(cmd: tuple[str, ...], dest: str) -> bool:
    return dest == "run_dir" or (dest == "out" and cmd[-1] not in OUT_IS_FILE)


@pytest.mark.parametrize(("cmd", "dest"), CASES, ids=[f"{' '.join(c)}:{d}" for c, d in CASES])
def test_a_planted_symlink_is_refused_and_its_target_kept(work, capsys, cmd, dest):
    if _is_folder(cmd, dest):
        names = FOLDER_NAMES.get(cmd[-1])
        if names is None:
            pytest.skip(f"{' '.join(cmd)} does not declare the names it writes: the writer refuses at write time "
                        f"(tests/test_io.py)")
        (work / "outdir").mkdir()
        for name in names:
            (work / "outdir" / name).symlink_to(work / "victim.bin")
        value = "outdir"
    else:
        (work / "link.out").symlink_to(work / "victim.bin")
        value = "link.out"
    code, err = _run(_argv(cmd, dest, value), capsys)
    assert code == 2 and "symbolic link" in err and err.count("\n") == 1, err
    assert (work / "victim.bin").read_bytes() == b"precious"


@pytest.mark.parametrize(("cmd", "dest"), CASES, ids=[f"{' '.join(c)}:{d}" for c, d in CASES])
def test_a_file_the_package_ships_is_never_an_output(work, capsys, cmd, dest):
    shipped = PACKAGE_ROOT / "data" / ("sample_map.png" if not _is_folder(cmd, dest) else "")
    before = sorted(os.listdir(PACKAGE_ROOT / "data"))
    code, err = _run(_argv(cmd, dest, str(shipped).rstrip("/")), capsys)
    assert code == 2 and err.count("\n") == 1, err
    assert sorted(os.listdir(PACKAGE_ROOT / "data")) == before


@pytest.mark.parametrize(("cmd", "dest"), [c for c in CASES if not _is_folder(*c)],
                         ids=[f"{' '.join(c)}:{d}" for c, d in CASES if not _is_folder(c, d)])
def test_a_hard_link_to_an_input_is_refused(work, capsys, cmd, dest):
    argv = _argv(cmd, dest, "twin.out")
    given = [a for a in argv if a in ("map.png", "ck.pt")]
    if not given:
        pytest.skip("the command reads no file named on its command line")
    os.link(work / given[0], work / "twin.out")
    before = (work / given[0]).read_bytes()
    code, err = _run(argv, capsys)
    assert code == 2 and ("input" in err or "this run reads" in err) and err.count("\n") == 1, err
    assert (work / given[0]).read_bytes() == before


def test_predict_names_in_its_folder_are_refused_one_by_one(work, capsys):
    for name in FOLDER_NAMES["predict"]:
        folder = work / f"o-{name}"
        folder.mkdir()
        (folder / name).symlink_to(work / "map.png")
        code, err = _run(["predict", "map.png", "--start", "0,0", "--goal", "5,5", "--out", str(folder)], capsys)
        assert code == 2 and name in err and "symbolic link" in err, err
    with Image.open(work / "map.png") as img:
        assert img.size == (12, 12)


# --- completeness: every write in src/ goes through ndrql.io.atomic ---------------------------------

#: Calls that write a file by name or into a handle; allowed only inside the writer's handle (a lambda or
#: function passed to atomic_write) or a ``with atomic_path(...)`` block.
WRITING_CALLS = {"save", "savez", "savez_compressed", "savefig", "write_text", "write_bytes", "export", "to_csv",
                 "tofile", "copy", "copyfile", "copy2", "move", "rename", "replace", "touch", "symlink_to",
                 "hardlink_to", "link", "symlink", "dump", "connect"}
WRITER_FUNCTIONS = {"atomic_write", "atomic_path", "write_text", "write_bytes", "write_json", "save_npz", "save_figure",
                    "open_log", "save_map", "save_checkpoint"}
#: The writer, and the lock files it keeps for folders shared by runs.
WRITER_MODULES = {SRC / "io" / "atomic.py", SRC / "io" / "locks.py"}
#: Names that are not file writes (``str.replace``, ``dataclasses.replace``, ``json.dump`` into a handle the
#: writer opened, a Path's ``write_text`` is a file write and stays listed).
NOT_FILES = {"replace", "dump", "copy", "export", "connect", "link"}


def _parents(tree: ast.AST) -> dict[ast.AST, ast.AST]:
    return {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}


def _name(func: ast.expr) -> str:
    return func.attr if isinstance(func, ast.Attribute) else func.id if isinstance(func, ast.Name) else ""


def _qualified(func: ast.expr) -> str:
    return ast.unparse(func)


def _inside_writer(node: ast.AST, parents: dict[ast.AST, ast.AST]) -> bool:
    """Inside a lambda/def handed to a writer function, or a ``with atomic_path(...)`` block."""
    while node in parents:
        node = parents[node]
        if isinstance(node, ast.With) and any(isinstance(i.context_expr, ast.Call)
                                              and _name(i.context_expr.func) in WRITER_FUNCTIONS for i in node.items):
            return True
        if isinstance(node, ast.Call) and _name(node.func) in WRITER_FUNCTIONS:
            return True
        if isinstance(node, (ast.FunctionDef, ast.Lambda)) and isinstance(parents.get(node), ast.Call) \
                and _name(parents[node].func) in WRITER_FUNCTIONS:
            return True
    return False


def _opens_for_writing(call: ast.Call) -> bool:
    if _name(call.func) != "open" or _qualified(call.func) in ("os.open",):
        return _qualified(call.func) == "os.open" and any("O_WRONLY" in ast.unparse(a) or "O_RDWR" in ast.unparse(a)
                                                             or "O_CREAT" in ast.unparse(a) for a in call.args[1:])
    modes = [a for a in call.args[1:2]] + [k.value for k in call.keywords if k.arg == "mode"]
    return any(isinstance(m, ast.Constant) and isinstance(m.value, str) and set(m.value) & set("wax+") for m in modes)


#: Writes that are not files ndrql produces, each with its reason.
ALLOWED = {("cli/__init__.py", "os.open"): "opens /dev/null to silence a closed stdout"}


def _suspect(call: ast.Call) -> bool:
    name, text = _name(call.func), _qualified(call.func)
    if isinstance(call.func, ast.Name) and name in WRITER_FUNCTIONS:
        return False  # ndrql.io's own functions
    if _opens_for_writing(call):
        return True
    if name not in WRITING_CALLS:
        return False
    if name in NOT_FILES:  # only the file-system forms
        return text in ("os.replace", "os.rename", "shutil.copy", "shutil.copyfile", "shutil.copy2", "shutil.move",
                        "torch.onnx.export", "os.link", "os.symlink", "sqlite3.connect", "pickle.dump", "json.dump")
    return True


def bypasses(root: Path = SRC) -> list[str]:
    """``file:line call`` for every write in ``root`` outside the writer."""
    found = []
    for path in sorted(root.rglob("*.py")):
        if path in WRITER_MODULES:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        parents = _parents(tree)
        calls = sorted((n for n in ast.walk(tree) if isinstance(n, ast.Call)), key=lambda n: (n.lineno, n.col_offset))
        for node in calls:
            if _suspect(node) and not _inside_writer(node, parents) \
                    and (path.relative_to(root).as_posix(), _qualified(node.func)) not in ALLOWED:
                found.append(f"{path.relative_to(root.parent)}:{node.lineno} {_qualified(node.func)}")
    return found


def test_no_module_writes_a_file_outside_the_writer():
    assert bypasses() == []


def test_the_completeness_scan_catches_a_new_write(tmp_path):
    pkg = tmp_path / "ndrql"
    pkg.mkdir()
    (pkg / "new.py").write_text("import numpy as np\nfrom pathlib import Path\n"
                                "def f(p, a, fig):\n    np.save(p, a)\n    Path(p).write_text('x')\n"
                                "    open(p, 'w').close()\n    fig.savefig(p)\n"
                                "def g(p, fig):\n    atomic_write(p, lambda fh: fig.savefig(fh))\n")
    assert [line.split(" ")[1] for line in bypasses(pkg)] == ["np.save", "Path(p).write_text", "open", "fig.savefig"]
