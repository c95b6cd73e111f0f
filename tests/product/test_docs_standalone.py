"""The repository's docs stand alone: no pointers outside the repo, the paper cited, links that resolve."""

from __future__ import annotations

import re

import pytest
import yaml

from helpers import REPO_ROOT

DOCS = [REPO_ROOT / "README.md", *sorted((REPO_ROOT / "docs").glob("*.md"))]
OUTSIDE = re.compile(r"\bSPEC\b|\bissue [0-9]|\.\./shared|ndr-ql\.tex|paper/")


@pytest.mark.parametrize("path", DOCS, ids=lambda p: p.name)
def test_no_pointers_outside_the_repository(path):
    hits = [f"{path.name}:{i}: {line.strip()[:120]}" for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
            if OUTSIDE.search(line)]
    assert not hits, "\n".join(hits)


@pytest.mark.parametrize("path", DOCS, ids=lambda p: p.name)
def test_relative_links_resolve(path):
    text = path.read_text(encoding="utf-8")
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if re.match(r"[a-z]+://", target):
            continue
        assert (path.parent / target).exists(), f"{path.name} links to missing {target}"


def test_citation_cites_the_paper():
    cff = yaml.safe_load((REPO_ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    paper = cff["preferred-citation"]
    assert cff["cff-version"] == "1.2.0" and paper["year"] == 2024
    assert " ".join(paper["title"].split()).startswith("Neural-Network-Driven Reward Prediction as a Heuristic")
    assert [a["family-names"] for a in paper["authors"]] == ["Ji", "Yun", "Liu", "Xie", "Liu"]
    assert any("2412.12650" in i["value"] for i in paper["identifiers"])
    readme = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    assert "arXiv:2412.12650" in readme and "CITATION.cff" in readme


def test_method_page_covers_every_equation_and_the_dataset_page_its_source():
    method = (REPO_ROOT / "docs" / "method.md").read_text(encoding="utf-8")
    for eq in range(1, 8):
        assert f"Eq. {eq}" in method or f"Eqs. {eq}" in method, f"Eq. {eq} missing"
    for constant in ("alpha = 0.1", "epsilon = 0.2", "gamma = 0.95", "W = 20", "r_max = 5", "0.99", "-10"):
        assert constant in method
    dataset = (REPO_ROOT / "docs" / "dataset.md").read_text(encoding="utf-8")
    assert "https://github.com/JimOriginal/path-planning-dataset" in dataset and "NDRQL_DATASET" in dataset
    assert (REPO_ROOT / "CHANGELOG.md").read_text(encoding="utf-8").startswith("# Changelog")


def _subcommands(parser):
    import argparse

    return next((a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction)), {})


def unknown_flags(text: str, root) -> list[str]:
    """Every ``--flag`` of an ``ndrql SUBCOMMAND ...`` command in ``text`` that SUBCOMMAND's parser does not define
    (``line: prog: flag``), so a page never tells a user to type a flag that is not there."""
    bad = []
    for i, line in enumerate(text.splitlines(), 1):
        for m in re.finditer(r"(?:^|[`$]\s*|\s)ndrql ([a-z][\w-]*(?: [^`#\n]*)?)", line):
            tokens, parser, k = m.group(1).split(), root, 0
            while k < len(tokens) and tokens[k] in _subcommands(parser):
                parser, k = _subcommands(parser)[tokens[k]], k + 1
            if parser is root:
                continue
            options = {s for a in parser._actions for s in a.option_strings}
            bad += [f"{i}: {parser.prog}: {t.split('=')[0].rstrip(',.;:)')}" for t in tokens[k:]
                    if t.startswith("--") and t.split("=")[0].rstrip(",.;:)") not in options]
    return bad


@pytest.mark.parametrize("path", [p for p in DOCS if p.name != "cli.md"], ids=lambda p: p.name)
def test_commands_in_the_docs_use_real_flags(path):
    from ndrql.cli import build_parser

    bad = unknown_flags(path.read_text(encoding="utf-8"), build_parser())
    assert not bad, f"{path.name}: " + "; ".join(bad)


def test_the_flag_check_finds_a_made_up_flag():
    from ndrql.cli import build_parser

    text = "run `ndrql plan map.png --start 1,2 --no-such-flag` or\n    ndrql map info m.png --gridd 3\n"
    assert unknown_flags(text, build_parser()) == ["1: ndrql plan: --no-such-flag", "2: ndrql map info: --gridd"]
