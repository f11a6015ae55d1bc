"""The documentation site (issue 36): ``mkdocs build --strict`` from docs/ and mkdocs.yml, as
``make docs`` runs it, builds without a warning, so that a broken link or anchor, a page missing
from the nav or an API name that no longer exists fails the fast tier; the CLI reference is the
parsers' own help; the campaign-file reference names every key the config accepts; the README stays
a short page that starts with the two commands."""

from __future__ import annotations

import dataclasses
import html
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from calibrax.cli import build_parser
from calibrax.core.config import CELL_KEYS, ROOT_KEYS, SURROGATE_CHOICES
from calibrax.core.registry import get_manager
from calibrax.core.sheartest import Geometry, Material, Numerics, Procedure, SizeDistribution
from tests.conftest import ROOT

DOCS = ROOT / "docs"
README_MAX_LINES = 150


def mkdocs_build(config: Path, site: Path) -> subprocess.CompletedProcess:
    """``make docs``'s build (the Material theme's notice about MkDocs 2.0 silenced as there)."""
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file", str(config),
                           "--site-dir", str(site)], capture_output=True, text=True, timeout=600,
                          cwd=config.parent, env=env)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("docs") / "site"
    build = mkdocs_build(ROOT / "mkdocs.yml", out)
    assert build.returncode == 0, build.stderr[-4000:]
    warnings = [line for line in build.stderr.splitlines() if "WARNING" in line]
    assert not warnings, "\n".join(warnings)
    return out


def page(site: Path, name: str) -> str:
    return (site / name / "index.html").read_text(encoding="utf-8")


def test_every_page_in_docs_is_built(site: Path) -> None:
    for source in DOCS.rglob("*.md"):
        relative = source.relative_to(DOCS).with_suffix("")
        built = site / ("index.html" if relative.name == "index" and relative.parent == Path(".")
                        else relative.parent / ("" if relative.name == "index" else relative.name) / "index.html")
        assert built.is_file(), f"{source} was not built into {built}"


def test_cli_reference_is_generated_from_the_parsers(site: Path) -> None:
    text = page(site, "reference/cli")
    commands = build_parser()._subparsers._group_actions[0].choices
    assert set(commands) >= {"run", "status", "export", "report", "crosscheck", "converge", "diagnose",
                             "diagnose-benchmark", "plugins"}
    for name, parser in commands.items():
        assert f"calibrax {name}" in text, f"`calibrax {name}` is not in the CLI reference"
        for action in parser._actions:
            for option in action.option_strings:
                assert option in text, f"{name} {option} is not in the CLI reference"


def test_api_reference_is_generated_from_the_docstrings(site: Path) -> None:
    text = "".join(p.read_text(encoding="utf-8") for p in (site / "reference").rglob("*.html"))
    for name in ("ShearCellSpec", "run_campaign", "CampaignStore", "Simulator", "TermsMetric", "Verification",
                 "SimulationFailed", "build_single_file_report"):
        assert f'id="calibrax.' in text and re.search(rf'id="calibrax\.[\w.]*\b{name}"', text), \
            f"{name} has no entry generated from its docstring"


def test_the_field_table_is_generated_from_the_declarations(site: Path) -> None:
    """Every declared field of the spec is in the campaign file's reference with the range that
    validation and the search boxes use (the table is written by docs/hooks/spec_fields.py)."""
    from calibrax.core.sheartest import ShearCellSpec
    from calibrax.core.sheartest.fields import declared_fields

    text = html.unescape(page(site, "reference/campaign-file"))
    for path, info in declared_fields(ShearCellSpec):
        assert f"<code>{path}</code>" in text, f"{path} is not in the generated field table"
        if info.numeric:
            assert info.interval() in text, (path, info.interval())
    assert "<!-- spec-fields -->" not in text


def test_campaign_reference_names_every_key() -> None:
    text = (DOCS / "reference/campaign-file.md").read_text(encoding="utf-8")
    keys = set(ROOT_KEYS) | CELL_KEYS | set(SURROGATE_CHOICES) | {"initial", "iterations", "patience", "q",
                                                                  "batching"}
    for spec in (Geometry, Material, Numerics, Procedure, SizeDistribution):
        keys |= {f.name for f in dataclasses.fields(spec)}
    manager = get_manager()
    for kind in ("metric", "acquisition", "executor"):
        for info in manager.plugins(kind).values():
            if info.distribution == "calibrax":
                keys |= set(getattr(info.cls, "OPTIONS", {}))
    missing = sorted(k for k in keys if f"`{k}`" not in text)
    assert not missing, f"docs/reference/campaign-file.md does not name: {missing}"


def test_a_broken_link_fails_the_strict_build(tmp_path: Path) -> None:
    """The strict build is a check that can fail: a link to a page that does not exist stops it."""
    shutil.copytree(DOCS, tmp_path / "docs")
    shutil.copy(ROOT / "mkdocs.yml", tmp_path / "mkdocs.yml")
    for linked in ("src", "plugins", "examples", "benchmarks", "tests"):  # what the pages include or document
        (tmp_path / linked).symlink_to(ROOT / linked)
    index = tmp_path / "docs/index.md"
    index.write_text(index.read_text(encoding="utf-8") + "\n[gone](tutorials/no-such-page.md)\n", encoding="utf-8")
    build = mkdocs_build(tmp_path / "mkdocs.yml", tmp_path / "site")
    assert build.returncode != 0 and "no-such-page.md" in build.stderr, build.stderr[-3000:]


def test_readme_is_short_and_starts_with_the_two_commands() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines (at most {README_MAX_LINES})"
    code = [line for line in lines[:12] if line.startswith("make ")]
    assert [line.split()[1] for line in code[:2]] == ["run", "test"], lines[:12]
    for link in re.findall(r"\]\((docs/[^)#]+)", "\n".join(lines)):
        assert (ROOT / link).is_file(), f"README links to {link}, which does not exist"
