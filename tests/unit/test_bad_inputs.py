"""Inputs a new user met that must give exit 2 and a one-line message naming the key or file and
what is allowed, with nothing lost or half-written (issue 21): duplicate YAML keys, YAML nested
thousands deep, a store whose folder is missing, read-only or a file, and stores that are refused
(not HDF5, another campaign's) — by a run and by ``run --check`` alike, leaving no lock file."""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

import pytest

from calibrax.cli import main
from calibrax.core.running.store import CampaignStore
from tests.conftest import write_double_campaign as write_campaign


def write_double_campaign(folder: Path, **changes) -> Path:
    """The double's campaign with the smallest budget (a run that is wrongly let through ends soon)."""
    return write_campaign(folder, **{"budget": {"initial": 2, "iterations": 0}, **changes})


def listing(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` with its content's digest (folders as "dir")."""
    return {str(p.relative_to(folder)): "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*"))}


def refused(capsys, *args: str) -> str:
    """Run the CLI in-process; assert exit 2 and a one-line error message without a traceback; return it."""
    code = main(list(args))
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert lines[-1].startswith("calibrax: error: "), err
    assert len([line for line in lines if line.startswith("calibrax: error:")]) == 1, err
    return lines[-1]


@pytest.fixture
def as_non_root(monkeypatch):
    """Under root, every folder is writable: make ``os.access`` answer from the mode bits, as it
    does for the user who met the defect (a no-op when the tests do not run as root)."""
    if os.geteuid() != 0:
        return
    real = os.access

    def by_mode(path, mode, *args, **kwargs):
        if mode & os.W_OK and not os.stat(path).st_mode & stat.S_IWUSR:
            return False
        return real(path, mode, *args, **kwargs)

    monkeypatch.setattr(os, "access", by_mode)


# ----------------------------------------------------------------------------- 1. duplicate keys
def test_duplicate_root_key_is_refused_naming_file_key_and_line(tmp_path, capsys):
    path = write_double_campaign(tmp_path)
    text = path.read_text()
    path.write_text(text + "parameters:\n  sliding_friction: {low: 0.2, high: 0.3}\n")
    line = len(text.splitlines()) + 1
    before = listing(tmp_path)
    message = refused(capsys, "run", str(path), "--check")
    assert str(path) in message and "duplicate key 'parameters'" in message and f"line {line}" in message, message
    assert listing(tmp_path) == before


def test_duplicate_nested_key_is_refused(tmp_path, capsys):
    path = write_double_campaign(tmp_path)
    lines = path.read_text().splitlines()
    at = next(i for i, line in enumerate(lines) if line.strip().startswith("low: 0.1"))
    lines.insert(at + 1, lines[at].replace("0.1", "0.3"))
    path.write_text("\n".join(lines) + "\n")
    message = refused(capsys, "run", str(path), "--check")
    assert str(path) in message and "duplicate key 'low'" in message and f"line {at + 2}" in message, message


def test_merge_keys_are_not_duplicates(tmp_path, capsys):
    """A YAML merge (``<<: *anchor``) whose keys an explicit key overrides is not a duplicate."""
    path = write_double_campaign(tmp_path)
    text = path.read_text().replace("parameters:\n  youngs_modulus:", "parameters:\n  youngs_modulus: &e")
    text = text.replace("  sliding_friction:\n    low: 0.1\n    high: 0.9\n",
                        "  sliding_friction:\n    <<: *e\n    low: 0.1\n    high: 0.9\n    log: false\n")
    path.write_text(text)
    assert main(["run", str(path), "--check"]) == 0, capsys.readouterr().err


def test_duplicate_key_in_an_experiment_header_is_refused(tmp_path, capsys):
    header = tmp_path / "exp.yaml"
    path = write_double_campaign(tmp_path, experiment="exp.yaml")
    header.write_text("points: exp.csv\nname: a\nname: b\n")
    message = refused(capsys, "run", str(path), "--check")
    assert str(header) in message and "duplicate key 'name'" in message and "line 3" in message, message


# ----------------------------------------------------------------------------- 2. deep nesting
@pytest.mark.parametrize("text", ["[" * 5000, "name: " + "{a: " * 5000, "- " * 3000 + "x"],
                         ids=["flow-lists", "flow-maps", "block-lists"])
def test_deeply_nested_yaml_is_refused(tmp_path, capsys, text):
    path = tmp_path / "campaign.yaml"
    path.write_text(text + "\n")
    message = refused(capsys, "run", str(path))
    assert str(path) in message and "nested" in message, message
    assert sorted(p.name for p in tmp_path.iterdir()) == ["campaign.yaml"]


def test_deeply_nested_experiment_header_is_refused(tmp_path, capsys):
    path = write_double_campaign(tmp_path, experiment="exp.yaml")
    (tmp_path / "exp.yaml").write_text("points: exp.csv\nsource: " + "[" * 5000 + "\n")
    message = refused(capsys, "run", str(path), "--check")
    assert "exp.yaml" in message and "nested" in message, message


# ----------------------------------------------------------------------------- 3. the store's folder
def test_a_store_folder_two_levels_missing_is_refused(tmp_path, capsys):
    path = write_double_campaign(tmp_path, store="no/such/double.h5")
    before = listing(tmp_path)
    for args in (["run", str(path)], ["run", str(path), "--check"]):
        message = refused(capsys, *args)
        assert "store" in message and str(tmp_path / "no/such") in message and "does not exist" in message, message
        assert listing(tmp_path) == before


def test_the_default_store_folder_one_level_missing_is_created(tmp_path, capsys):
    """``store: runs/double.h5`` in a fresh folder: --check accepts it and writes nothing."""
    path = write_double_campaign(tmp_path)
    assert main(["run", str(path), "--check"]) == 0, capsys.readouterr().err
    assert not (tmp_path / "runs").exists()
    assert CampaignStore(tmp_path / "runs/double.h5").check("any") is False
    assert not (tmp_path / "runs").exists()


def assert_run_and_check_refuse(capsys, tmp_path: Path, path: Path, *words: str) -> None:
    """A run and ``run --check`` of ``path`` both exit 2 with every one of ``words`` in the message,
    and leave ``tmp_path`` as it was."""
    before = listing(tmp_path)
    for args in (["run", str(path)], ["run", str(path), "--check"]):
        message = refused(capsys, *args)
        assert all(word in message for word in words), message
        assert listing(tmp_path) == before


def test_a_store_under_a_file_is_refused(tmp_path, capsys):
    (tmp_path / "notes").write_text("not a folder\n")
    for store in ("notes/double.h5", "notes/runs/double.h5"):
        path = write_double_campaign(tmp_path, store=store)
        assert_run_and_check_refuse(capsys, tmp_path, path, "store", str(tmp_path / "notes"), "not a folder")


@pytest.mark.parametrize("store", ["ro/double.h5", "ro/runs/double.h5"])
def test_a_store_in_a_read_only_folder_is_refused(tmp_path, capsys, as_non_root, store):
    (tmp_path / "ro").mkdir()
    (tmp_path / "ro").chmod(0o555)
    try:
        path = write_double_campaign(tmp_path, store=store)
        assert_run_and_check_refuse(capsys, tmp_path, path, "store", str(tmp_path / "ro"), "not writable")
    finally:
        (tmp_path / "ro").chmod(0o755)


# ----------------------------------------------------------------------------- 4, 5. refused stores
def not_hdf5(store: Path) -> None:
    store.write_text("these are my notes, not an HDF5 file\n")


def another_campaigns(store: Path) -> None:
    with CampaignStore(store).acquire() as s:
        s.initialise("0123456789abcdef", {"name": "another"}, "0")
    store.with_name(store.name + ".lock").unlink()


@pytest.mark.parametrize("make, message", [(not_hdf5, "cannot be opened as HDF5"),
                                           (another_campaigns, "different settings")],
                         ids=["not-hdf5", "another-campaign"])
@pytest.mark.parametrize("check", [True, False], ids=["check", "run"])
def test_a_refused_store_is_refused_by_check_and_run_and_no_file_is_left(tmp_path, capsys, make, message, check):
    path = write_double_campaign(tmp_path)
    (tmp_path / "runs").mkdir()
    store = tmp_path / "runs/double.h5"
    make(store)
    before = listing(tmp_path)
    text = refused(capsys, "run", str(path), *(["--check"] if check else []))
    assert "store" in text and str(store) in text and message in text, text
    assert listing(tmp_path) == before  # no .lock, no .tmp, the store unchanged


def test_check_accepts_this_campaigns_own_store(tmp_path, capsys):
    from calibrax.core.config import load_config

    path = write_double_campaign(tmp_path)
    config = load_config(path)
    with CampaignStore(config.store).acquire() as s:
        s.initialise(config.search_hash(), config.resolved, "0")
    before = listing(tmp_path)
    assert main(["run", str(path), "--check"]) == 0, capsys.readouterr().err
    assert listing(tmp_path) == before
