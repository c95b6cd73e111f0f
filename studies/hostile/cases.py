"""The cases of the hostile campaign (campaign.py): fixtures, setups and the generated cases per family.

Families: ``flags`` (every numeric flag of every subcommand just outside its declared range, from the
parsers themselves), ``outputs`` (every output flag aimed at inputs, the package, links and folders),
``folders`` (links planted under the names an output folder receives), ``env`` (NDRQL_* variables),
``inputs`` (hostile files), ``api`` (calls of the public API with wrong kinds and values).
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
from pathlib import Path

import numpy as np
from PIL import Image

PACKAGE = Path(__file__).resolve().parents[2] / "src" / "ndrql"
SHIPPED_MAP = PACKAGE / "data" / "sample_map.png"
SHIPPED_WEIGHTS = PACKAGE / "data" / "ndr_default.pt"
PTS = ("--start", "1,1", "--goal", "38,38")
PLAN = ("plan", "map.png", *PTS, "--method", "IQL")
ASTAR = ("astar", "map.png", *PTS)


def fixtures(folder: Path) -> None:
    """The files every case starts from (copied into its own folder)."""
    arr = np.full((40, 40), 255, np.uint8)
    arr[10:30, 20] = 0
    Image.fromarray(arr).save(folder / "map.png")
    (folder / "map.yaml").write_text("image: map.png\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"
                                     "occupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: 0\n")
    rows = ["." * 40] * 40
    (folder / "arena.map").write_text("type octile\nheight 40\nwidth 40\nmap\n" + "\n".join(rows) + "\n")
    (folder / "arena.map.scen").write_text("version 1\n0\tarena.map\t40\t40\t1\t1\t30\t30\t41.0122\n")
    (folder / "victim.bin").write_bytes(b"precious data\n")
    (folder / "preset.json").write_text((PACKAGE / "planning" / "presets" / "spec.json").read_text())
    (folder / "sub").mkdir()


def plant(work: Path, step: str) -> None:
    """One setup step: ``link:NAME->TARGET``, ``hard:NAME->TARGET``, ``mkdir:NAME``, ``write:NAME=TEXT``,
    ``copy:NAME<-SOURCE``, ``ro:NAME`` (read-only folder), ``fifo:NAME``."""
    kind, _, rest = step.partition(":")
    if kind in ("link", "hard"):
        name, target = rest.split("->", 1)
        (work / name).parent.mkdir(parents=True, exist_ok=True)
        if kind == "link":
            os.symlink(target, work / name)
        else:
            os.link(work / target, work / name)
    elif kind == "mkdir":
        (work / rest).mkdir(parents=True, exist_ok=True)
    elif kind == "write":
        name, text = rest.split("=", 1)
        (work / name).write_bytes(text.encode("latin-1"))
    elif kind == "copy":
        name, source = rest.split("<-", 1)
        shutil.copy2(source, work / name)
    elif kind == "ro":
        (work / rest).mkdir(exist_ok=True)
        os.chmod(work / rest, 0o555)
    elif kind == "fifo":
        os.mkfifo(work / rest)
    elif kind == "pt":  # a crafted checkpoint (needs torch): zero-stride or absurd shapes
        import torch

        from ndrql.model.checkpoint import FORMAT, FORMAT_VERSION

        name, how = rest.split("=", 1)
        t = torch.zeros(1).expand(60000, 60000) if how == "stride0" else torch.zeros(int(how))
        torch.save({"format": FORMAT, "format_version": FORMAT_VERSION, "config": {}, "model": {"w": t}}, work / name)
    else:
        raise ValueError(step)


def case(family: str, argv=(), expect: str = "refuse", needle: str = "", setup=(), env=None, api: str = "",
         stdout: str = "") -> dict:
    c = {"family": family, "expect": expect, "needle": needle, "setup": tuple(setup), "env": dict(env or {})}
    if api:
        c["api"] = api
    else:
        c["argv"] = tuple(argv)
    if stdout:
        c["stdout"] = stdout
    return c


# --- flags: every numeric flag just outside its range ----------------------------------------------------

def _leaves(parser, prefix=()):
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield prefix, parser
        return
    for name, sub in subs[0].choices.items():
        yield from _leaves(sub, prefix + (name,))


def _base(cmd: tuple[str, ...], parser) -> list[str]:
    argv = list(cmd)
    for a in parser._actions:
        if not a.option_strings and (a.nargs not in ("?", "*") or a.dest == "map") and a.dest != "help":
            argv.append({"map": "map.png", "set": "sub", "target": "table1", "checkpoint": "victim.bin",
                         "weights": "victim.bin", "output": "new.png"}.get(a.dest, "x"))
        elif a.required:
            argv += [a.option_strings[-1], {"count": "1", "out": "outdir", "family": "all"}.get(a.dest, "x")]
    return argv


def _outside(bound, rng: random.Random) -> list[str]:
    """A value below and one above ``bound`` (not its ``off`` value), as text."""
    lo, hi = bound.lo, bound.hi
    below = lo - 1 if bound.integer else (lo / 1000 if lo > 0 else lo - abs(lo) - 1)
    if bound.off is not None and below == bound.off:
        below = lo - 2 if bound.integer else -1.0
    above = hi * 10 + 1 if hi < 1e15 else 2**64
    fmt = (lambda v: str(int(v))) if bound.integer else (lambda v: repr(float(v)))
    return [fmt(below), fmt(above)] + ([rng.choice(["nan", "inf", "-inf"])] if not bound.integer else ["1.5"])


def flag_cases(rng: random.Random) -> list[dict]:
    from ndrql.cli import build_parser
    from ndrql.cli.options import numeric_values
    from ndrql.limits import bound_for

    out = []
    for cmd, parser in _leaves(build_parser()):
        base = _base(cmd, parser)
        for a in parser._actions:
            if not a.option_strings or a.choices is not None or a.option_strings[-1] == "--model-overrides":
                continue
            if not (a.type in (int, float) or numeric_values(a.default)):
                continue
            bound = bound_for(a.option_strings[-1], " ".join(cmd))
            if bound is None:
                continue
            value = rng.choice(_outside(bound, rng))  # one of below, above, not a number: seeded
            out.append(case("flags", [*base, f"{a.option_strings[-1]}={value}"], needle=a.option_strings[-1]))
    return out


# --- outputs ----------------------------------------------------------------------------------------------

OUTPUT_COMMANDS = [
    (PLAN, "--json"), (PLAN, "--png"), (("plan", "map.yaml", *PTS, "--method", "IQL"), "--path-out"), (ASTAR, "--json"), (ASTAR, "--png"),
    (("astar", "map.yaml", "--start-world", "0.1,0.1", "--goal-world", "1.8,1.8"), "--path-out"),
    (("map", "info", "map.png"), "--json"), (("map", "convert", "map.png"), None),
    (("plan", "arena.map", "--scen", "arena.map.scen", "--all", "--method", "IQL"), "--jsonl"),
    (("astar", "arena.map", "--scen", "arena.map.scen", "--all"), "--jsonl"),
]
#: Setup and expected outcome per hostile target of an output.
TARGETS = [
    ("link.out", ["link:link.out->map.png"], "refuse", "symbolic link"),
    ("plink.out", [f"link:plink.out->{SHIPPED_MAP}"], "refuse", "symbolic link"),
    ("dangling.out", ["link:dangling.out->nowhere/x"], "refuse", "symbolic link"),
    ("hard.out", ["hard:hard.out->map.png"], "refuse", ""),
    ("sub/../map.png", [], "refuse", ""),
    (str(PACKAGE / "data" / "new-output.json"), [], "refuse", "package"),
    (str(SHIPPED_MAP), [], "refuse", ""),
    ("victim.bin/x.json", [], "refuse", ""),
    ("folder.out", ["mkdir:folder.out"], "refuse", "folder"),
    ("ro/x.out", ["ro:ro"], "refuse" if os.geteuid() != 0 else "ok", "ermission"),  # root writes anyway
    ("e\x1b]0;t\x07.out", [], "ok", ""),
    ("/dev/null", [], "ok", ""),
]


def output_cases() -> list[dict]:
    out = []
    for argv, flag in OUTPUT_COMMANDS:
        for name, setup, expect, needle in TARGETS:
            if expect == "ok" and argv[0] == "map" and name == "/dev/null":
                continue
            ext = {"--png": ".png", "--path-out": ".yaml", None: ".png"}.get(flag, ".json")
            target = name if not name.endswith(".out") else name[:-4] + ext
            setup = [s.replace(".out", ext) for s in setup]
            full = [*argv, target] if flag is None else [*argv, flag, target]
            out.append(case("outputs", full, expect, needle, setup))
    out.append(case("outputs", [*PLAN, "--json", "same.json", "--png", "same.json"], "refuse", "both write"))
    out.append(case("outputs", ["plan", "map.yaml", *PTS, "--method", "IQL", "--json", "map.yaml"], "refuse", ""))
    out.append(case("outputs", ["plan", "map.yaml", *PTS, "--method", "IQL", "--png", "map.png"], "refuse", ""))
    return out


MORE_OUTPUTS = [
    (("eval", "--weights", "victim.bin"), "--json", ".json"), (("eval", "--weights", "victim.bin"), "--markdown", ".md"),
    (("data", "show", "sub"), "--png", ".png"), (("export-weights", "victim.bin"), "--out", ".pt"),
    (("average-weights", "victim.bin", "victim.bin"), "--out", ".pt"), (("export-onnx",), "--out", ".onnx"),
    (("tune", "--method", "IQL"), "--export-preset", ".json"),
]


def more_output_cases() -> list[dict]:
    """The other commands' outputs: a link to an input, a name inside the package, a hard link to an input."""
    out = []
    for argv, flag, ext in MORE_OUTPUTS:
        for target, setup, needle in ((f"l{ext}", [f"link:l{ext}->victim.bin"], "symbolic link"),
                                      (str(PACKAGE / "planning" / "presets" / f"new{ext}"), [], "package"),
                                      (f"h{ext}", [f"hard:h{ext}->victim.bin"], "victim.bin")):
            if needle == "victim.bin" and "victim.bin" not in argv:  # a hard link to a file the command does not
                c = case("more-outputs", [*argv, flag, target], "any", "", setup)  # read: the name is replaced,
                c["allow"] = (target,)  # the other name keeps its contents
            else:
                c = case("more-outputs", [*argv, flag, target], "refuse", needle, setup)
            out.append(c)
    out.append(case("more-outputs", ["export-onnx", "--out", "g.onnx"], "refuse", "symbolic link",
                    ["link:g.json->victim.bin"]))
    out.append(case("more-outputs", ["predict", "map.png", *PTS, "--out", "o"], "refuse", "package",
                    [f"link:o->{PACKAGE / 'data'}"]))
    out.append(case("more-outputs", ["plan", "map.png", *PTS, "--method", "NDR-QL", "--prior-from", "model"], "any", "",
                    env={"NDRQL_CACHE": str(PACKAGE / "data")}))
    return out


# --- folders ----------------------------------------------------------------------------------------------

def folder_cases() -> list[dict]:
    out = []
    for name in ("prediction.npz", "region.png", "guideline.png", "distance.png"):
        out.append(case("folders", ["predict", "map.png", *PTS, "--out", "o"], "refuse", "symbolic link",
                        ["mkdir:o", f"link:o/{name}->../map.png"]))
    for name in ("compare.png", "ndr-ql.png", "results.json", "table.md"):
        out.append(case("folders", ["demo", "--seeds", "1", "--out", "o"], "refuse", "symbolic link",
                        ["mkdir:o", f"link:o/{name}->../victim.bin"]))
    out.append(case("folders", ["predict", "map.png", *PTS, "--out", str(PACKAGE / "data")], "refuse", "package"))
    out.append(case("folders", ["predict", "map.png", *PTS, "--out", "."], "ok", ""))  # its names are not the map
    out.append(case("folders", ["train", "--run-dir", "r", "--epochs", "1"], "refuse", "symbolic link",
                    ["mkdir:r", "link:r/last.pt->../victim.bin"]))
    out.append(case("folders", ["train", "--run-dir", "r", "--epochs", "1"], "refuse", "symbolic link",
                    ["mkdir:r", "link:r/metrics.csv->../victim.bin"]))
    out.append(case("folders", ["tune", "--method", "IQL", "--out", "t"], "refuse", "symbolic link",
                    ["mkdir:t", "link:t/studies.db->../victim.bin"]))
    out.append(case("folders", ["tune", "--method", "IQL", "--storage", "sqlite:///t"], "refuse", "folder", ["mkdir:t"]))
    out.append(case("folders", ["tune", "--method", "IQL", "--storage", "sqlite:///map.png"], "refuse", "SQLite"))
    return out


# --- environment ------------------------------------------------------------------------------------------

def env_cases() -> list[dict]:
    out = []
    for v in ("bogus", "C ", "numba\x1b[31m", "", "auto,c", "x" * 5000):
        expect = "ok" if v.strip().lower() in ("", "c", "auto") else "refuse"
        out.append(case("env", PLAN, expect, "NDRQL_KERNELS", env={"NDRQL_KERNELS": v}))
    for v, needle in (("missing.pt", "missing.pt"), ("sub", "sub"), ("victim.bin", "victim.bin"), ("map.png", "map.png"),
                      ("general ", "general"), ("/dev/null", "null"), ("paper\x07", "paper")):
        out.append(case("env", ["plan", "map.png", *PTS, "--method", "NDR-QL", "--prior-from", "model"], "refuse",
                        needle, env={"NDRQL_WEIGHTS": v}))
    for v, setup in (("victim.bin", []), (str(PACKAGE / "data"), []), ("ro", ["ro:ro"]), ("lnk", ["link:lnk->victim.bin"])):
        out.append(case("env", ["plan", "map.png", *PTS, "--method", "NDR-QL", "--prior-from", "model"], "any", "",
                        setup, env={"NDRQL_CACHE": v}))
    for v in ("abc", "0", "-3", "99999"):
        out.append(case("env", api="from ndrql.limits import env_number; env_number('NDRQL_EVAL_THREADS', 1)",
                        expect="refuse", needle="NDRQL_EVAL_THREADS", env={"NDRQL_EVAL_THREADS": v}))
    out.append(case("env", ["data", "show", "--png", "s.png"], "refuse", "", env={"NDRQL_DATASET": "victim.bin"}))
    return out


# --- hostile input files ----------------------------------------------------------------------------------

def input_cases() -> list[dict]:
    y = "image: map.png\norigin: [0.0, 0.0, 0.0]\noccupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: 0\n"
    out = [case("inputs", ["map", "info", "m.yaml", "--json", "-"], "ok", "", [f"write:m.yaml=resolution: 010\n{y}"],
                stdout='"resolution": 10'),
           case("inputs", ["map", "info", "m.yaml", "--json", "-"], "ok", "", [f"write:m.yaml=resolution: 0.050\n{y}"],
                stdout='"resolution": 0.05'),
           case("inputs", ["map", "info", "m.yaml"], "refuse", "resolution", [f"write:m.yaml=resolution: 0x0\n{y}"]),
           case("inputs", ["map", "info", "m.yaml"], "refuse", "", ["write:m.yaml=" + "a: " + "[" * 5000]),
           case("inputs", ["map", "info", "m.yaml"], "refuse", "", ["write:m.yaml=a: &a [*a, *a]\n"]),
           case("inputs", ["map", "info", "m.yaml"], "refuse", "", [f"write:m.yaml=resolution: .inf\n{y}"]),
           case("inputs", ["map", "info", "m.yaml"], "refuse", "", [f"write:m.yaml=resolution: 1e-300\n{y}"]),
           case("inputs", ["map", "info", "m.yaml"], "refuse", "", ["write:m.yaml=image: /dev/zero\nresolution: 1\n"
                                                                     "origin: [0,0,0]\noccupied_thresh: 0.6\nfree_thresh: 0.1\n"]),
           case("inputs", ["map", "info", "e.png"], "refuse", "", ["write:e.png="]),
           case("inputs", ["map", "info", "z.npy"], "refuse", "", ["write:z.npy=\x93NUMPY\x01\x00v\x00{'descr': '<f8', "
                                                                   "'fortran_order': False, 'shape': (100000, 100000), }" + " " * 40 + "\n"]),
           case("inputs", ["map", "info", "h.map"], "refuse", "", ["write:h.map=type octile\nheight 99999999\nwidth 99999999\nmap\n"]),
           case("inputs", ["map", "info", "h.map"], "refuse", "", ["write:h.map=type octile\nheight -4\nwidth 4\nmap\n"]),
           case("inputs", ["plan", "arena.map", "--scen", "s.scen", "--method", "IQL"], "refuse", "",
                ["write:s.scen=version 1\n0\tarena.map\t40\t40\t-5\t1\t30\t30\t41\n"]),
           case("inputs", ["plan", "arena.map", "--scen", "s.scen", "--method", "IQL"], "refuse", "",
                ["write:s.scen=version 1\n0\tarena.map\t40\t40\t1\t1\t30\t30\tnan\n"]),
           case("inputs", ["plan", "arena.map", "--scen", "arena.map.scen:99", "--method", "IQL"], "refuse", "99"),
           case("inputs", ["plan", "arena.map", "--scen", "s.scen:1", "--method", "IQL"], "refuse", "scenario file"),
           case("inputs", ["plan", "map.png", *PTS, "--preset", "p.json"], "refuse", "", ["write:p.json={}"]),
           case("inputs", ["plan", "map.png", *PTS, "--preset", "p.json"], "refuse", "", ["write:p.json=[1, 2]"]),
           case("inputs", ["plan", "map.png", *PTS, "--preset", "p.json"], "refuse", "",
                ["write:p.json=" + '{"a":' * 5000 + "1" + "}" * 5000]),
           case("inputs", ["plan", "map.png", *PTS, "--preset", "sub"], "refuse", "sub"),
           case("inputs", ["plan", "map.png", *PTS, "--preset", "victim.bin"], "refuse", "victim.bin"),
           case("inputs", ["plan", "bomb.png", *PTS], "refuse", "", ["copy:bomb.png<-" + str(_bomb())]),
           case("inputs", ["plan", "map.png", "--start", "1,1", "--goal", "10,20", "--method", "IQL"], "refuse", "obstacle"),
           case("inputs", ["plan", "map.png", "--start", "1,1", "--goal", "999999999999,1"], "refuse", "goal"),
           case("inputs", ["plan", "map.png", "--start", "1,1", "--goal", "\x1b[2J,1"], "refuse", "--goal"),
           case("inputs", ["plan", "map.png", *PTS, "--weights", "w.pt", "--prior-from", "model"], "refuse", "w.pt",
                ["pt:w.pt=stride0"]),
           case("inputs", ["average-weights", "w.pt", "w.pt", "--out", "a.pt"], "refuse", "w.pt", ["pt:w.pt=stride0"]),
           case("inputs", ["export-weights", "w.pt", "--out", "a.pt"], "refuse", "w.pt", ["pt:w.pt=stride0"]),
           case("inputs", ["average-weights", str(SHIPPED_WEIGHTS), str(SHIPPED_WEIGHTS), "--shares", "inf,1", "--out",
                           "a.pt"], "refuse", "share"),
           case("inputs", ["average-weights", str(SHIPPED_WEIGHTS), str(SHIPPED_WEIGHTS), "--shares", "1e-300,1e300",
                           "--out", "a.pt"], "refuse", "share"),
           case("inputs", ["average-weights", str(SHIPPED_WEIGHTS), str(SHIPPED_WEIGHTS), "--shares", "1,-1", "--out",
                           "a.pt"], "refuse", "share"),
           case("inputs", ["train", "--model-overrides", "[" * 100_000], "refuse", "--model-overrides"),
           case("inputs", ["map", "info", "\x1b]0;x\x07.png"], "ok", "", ["copy:\x1b]0;x\x07.png<-" + str(SHIPPED_MAP)])]
    return out


def _bomb() -> Path:
    """A 45-byte PNG whose header says 60000 x 60000 pixels (written by hand: Pillow would build the image)."""
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    path = Path(os.environ.get("TMPDIR", "/tmp")) / "ndrql-hostile-bomb.png"
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 60000, 60000, 1, 0, 0, 0, 0))
                     + chunk(b"IEND", b""))
    return path


# --- the API ----------------------------------------------------------------------------------------------

API_PLAN = "ndrql.solve('map.png', (1, 1), (38, 38), {kw})"


def api_cases() -> list[dict]:
    bad = ["config={}", "preset={}", "weights=5", "preset=5", "ql=[]", "priors=5", "prior_config={}", "settings={}",
           "settings=5", "methods=5", "methods=[{}]", "seeds='x'", "seeds=-1", "seeds=[1.5]", "seeds=10**30",
           "start_world='x'", "scen=5", "scen_index='a'", "robot_radius='x'", "robot_radius=1e300", "size={}",
           "size=10**9", "grid=5", "threads='a'", "threads=10**6", "symmetries=3", "fallback=5", "backend=5",
           "max_size=10**9", "tolerance=float('nan')", "max_map_pixels='many'", "ql={'alpha': {}}",
           "ql={'thd_step': 1e-300}", "priors={'thd_step': 1e-300}", "priors={'g_row': float('inf')}",
           "ql={'window': 10**10}", "ql={'max_episodes': 10**12}", "priors={'nonsense': 1}", "info=5", "hide=5",
           "unknown=5", "sense=-1", "sense_every=0", "predictions=5", "invert='x'", "threshold='x'", "crop=[]"]
    out = [case("api", api=API_PLAN.format(kw=kw if kw.startswith("methods") else f"methods=['IQL'], {kw}"),
                expect="refuse") for kw in bad]
    for call in ("ndrql.plan(5, (1, 1), (2, 2))", "ndrql.plan('map.png', 'x', (2, 2))", "ndrql.plan('map.png', (1, 1, 1), (2, 2))",
                 "ndrql.plan(None)", "ndrql.plan({})", "ndrql.plan('map.png', (1, 1), (38, 38), 'IQL', nonsense=1)",
                 "ndrql.plan('map.png', (1, 1), (38, 38), method='IQL', seed=-1)", "ndrql.astar('map.png', (1, 1), (38, 38), robot_radius='x')",
                 "ndrql.astar('map.png', (1, 1), (38, 38), size=10**9)", "ndrql.astar(b'map.png', (1, 1), (38, 38))",
                 "ndrql.astar('map.png', (1.5, 1), (38, 38))", "ndrql.astar('map.png', (1, 1), (38, 38), max_map_pixels=-1)",
                 "ndrql.solve('map.png', (1, 1), (38, 38), workers=10**6)", "ndrql.solve('map.png', (1, 1), (38, 38), workers='x')",
                 "ndrql.build_request('map.png', (1, 1), (38, 38), methods='nope')",
                 "ndrql.PlanSettings(robot_radius=float('nan'))", "ndrql.PlanSettings(threads=True)"):
        out.append(case("api", api=call, expect="refuse"))
    return out


def all_cases(folder: Path) -> list[dict]:
    fixtures(folder)
    rng = random.Random(56)
    return flag_cases(rng) + output_cases() + more_output_cases() + folder_cases() + env_cases() + input_cases() + api_cases()

