"""What each subcommand writes and reads, from its parsed flags, for the output guard.

:func:`guard` is called by :func:`ndrql.cli.main` for every subcommand before it runs: it lists the
outputs (``--json``, ``--png``, ``--path-out``, ``--jsonl``, ``--markdown``, ``--export-preset``,
``map convert``'s target, ``--out`` files and folders) and the inputs (the map and a ROS YAML's
image, ``--scen``, ``--weights`` and ``$NDRQL_WEIGHTS``, presets, ``--prior-from``, checkpoints,
dataset and set folders) and hands them to :func:`ndrql.io.guard.check_outputs`, which refuses any
output that would replace an input or another output (one line, exit code 2, nothing written).
A new subcommand's flags are covered when they use these names.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Iterator

from ndrql.io.guard import Input, Output, check_outputs
from ndrql.io.readset import note_input
from ndrql.maps.readers import map_files

#: Output files by flag name (``dest``): the flag as the user writes it, and whether ``-`` is stdout.
FILE_OUTPUTS: dict[str, tuple[str, bool]] = {
    "json": ("--json", True),
    "png": ("--png", False),
    "path_out": ("--path-out", False),
    "jsonl": ("--jsonl", False),
    "markdown": ("--markdown", False),
    "export_preset": ("--export-preset", False),
    "output": ("OUTPUT", False),
}

#: Commands whose ``--out`` is one file (the others write a folder).
OUT_IS_FILE = ("export-weights", "average-weights", "export-onnx")

#: Files a command writes in its ``--out`` folder, when known (else no input may lie in the folder).
FOLDER_NAMES: dict[str, tuple[str, ...]] = {
    "predict": ("prediction.npz", "region.png", "guideline.png", "distance.png"),
    "demo": ("compare.png", "ndr-ql.png", "results.json", "table.md"),
    "train": ("last.pt", "best.pt", "metrics.csv"),
}

#: Input files by flag name: the flag as the user writes it.
FILE_INPUTS: dict[str, str] = {
    "scen": "--scen",
    "prior_from": "--prior-from",
    "checkpoint": "CHECKPOINT",
    "rgp_weights": "--rgp-weights",
    "start_from": "--start-from",
}

#: Input folders by flag name.
FOLDER_INPUTS: dict[str, str] = {"data": "--data", "runs": "--runs", "set": "SET"}


def _command(args: argparse.Namespace) -> str:
    return str(getattr(args, "command", "") or "")


def _existing(flag: str, value: object) -> Iterator[Input]:
    """``value`` as an input file when it names one (``paper`` and other names that are not files are skipped)."""
    if isinstance(value, (str, os.PathLike)) and str(value) and str(value) != "-":
        path = str(value)
        if os.path.isfile(path):
            yield Input(flag, path)


def inputs(args: argparse.Namespace) -> list[Input]:
    """Every file and folder the command reads, as far as its flags say."""
    found: list[Input] = []
    given = getattr(args, "map", None)
    if isinstance(given, (str, os.PathLike)) and str(given):
        found += [Input("MAP" if i == 0 else "MAP's image", str(p)) for i, p in enumerate(map_files(given))]
    sample = getattr(args, "sample", None)
    if isinstance(sample, str) and sample.count(":") >= 2:
        found.append(Input("--sample", sample.rsplit(":", 2)[0], folder=True))
    for dest, flag in FILE_INPUTS.items():
        value = getattr(args, dest, None)
        found += _existing(flag, value)
        if dest == "scen" and isinstance(value, str) and ":" in value:  # FILE:K
            found += _existing(flag, value.rpartition(":")[0])
    weights = getattr(args, "weights", None)
    for value in weights if isinstance(weights, list) else [weights]:
        found += _existing("--weights" if not isinstance(weights, list) else "WEIGHTS", value)
    if weights is None and os.environ.get("NDRQL_WEIGHTS"):
        found += _existing("$NDRQL_WEIGHTS", os.environ["NDRQL_WEIGHTS"])
    preset = getattr(args, "preset", None)
    if isinstance(preset, str):
        for part in preset.split(","):
            found += _existing("--preset", part.strip())
    for dest, flag in FOLDER_INPUTS.items():
        value = getattr(args, dest, None)
        if isinstance(value, (str, os.PathLike)) and os.path.isdir(value):
            found.append(Input(flag, str(value), folder=True))
    return found


def outputs(args: argparse.Namespace) -> list[Output]:
    """Every file and folder the command writes, as far as its flags say."""
    found: list[Output] = []
    for dest, (flag, stdout) in FILE_OUTPUTS.items():
        value = getattr(args, dest, None)
        if isinstance(value, (str, os.PathLike)):
            found.append(Output(flag, os.fspath(value), stdout=stdout))
    out = getattr(args, "out", None)
    command = _command(args)
    if isinstance(out, (str, os.PathLike)):
        out = os.fspath(out)
        if command in OUT_IS_FILE:
            found.append(Output("--out", out))
            if command == "export-onnx" and out != "-":
                found.append(Output("--out's record", str(Path(out).with_suffix(".json"))))
        else:
            found.append(Output("--out", out, folder=True, names=FOLDER_NAMES.get(command)))
    run_dir = getattr(args, "run_dir", None)
    if isinstance(run_dir, (str, os.PathLike)):
        found.append(Output("--run-dir", os.fspath(run_dir), folder=True, names=FOLDER_NAMES.get(command)))
    return found


def guard(args: argparse.Namespace) -> None:
    """Refuse, before the command runs, any output that would replace one of its inputs or another output;
    record the inputs in the run's input set (:mod:`ndrql.io.readset`), which the writer checks again."""
    ins = inputs(args)
    for inp in ins:
        if not inp.folder:
            note_input(inp.path, inp.flag)
    outs = outputs(args)
    if outs:
        check_outputs(outs, ins)
