"""A pseudo-experiment made through a store (the ``converged`` cell's replicates take 42
CPU-minutes each): the same files as the in-memory way, and a rerun repeats no replicate. On the
analytic TEST DOUBLE (core machinery only)."""

from __future__ import annotations

from pathlib import Path

import pytest

from calibrax import ShearCellSpec
from calibrax.core.data.pseudo import write_pseudo_experiment
from calibrax.core.studies.pseudo_study import write_pseudo_experiment_resumably
from calibrax.errors import ConfigError
from tests.conftest import completions_logged


def _spec() -> ShearCellSpec:
    return ShearCellSpec.preset("tiny", material={"youngs_modulus": 2e10, "sliding_friction": 0.45})


def test_a_stored_pseudo_experiment_writes_the_same_files_and_resumes(tmp_path: Path) -> None:
    direct = write_pseudo_experiment(_spec(), "analytic_double", tmp_path / "direct" / "exp", 3)
    store = tmp_path / "stored" / "replicates.h5"
    stored = write_pseudo_experiment_resumably(_spec(), "analytic_double", tmp_path / "stored" / "exp", store, 3)
    for suffix in (".yaml", "-points.csv", "-curves.csv"):
        a = (direct.parent / f"exp{suffix}").read_text()
        b = (stored.parent / f"exp{suffix}").read_text()
        assert a == b, suffix
    runs = store.with_suffix(".runs")
    assert completions_logged(runs) == 3
    (stored.parent / "exp.yaml").unlink()
    again = write_pseudo_experiment_resumably(_spec(), "analytic_double", tmp_path / "stored" / "exp", store, 3)
    assert again.read_text() == direct.read_text()
    assert completions_logged(runs) == 3, "a rerun ran a replicate again"


def test_a_replicate_seed_where_campaigns_draw_theirs_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="seed.*must be ≥ 1073741824"):
        write_pseudo_experiment_resumably(_spec(), "analytic_double", tmp_path / "exp", tmp_path / "r.h5", 3,
                                          first_seed=5)
    assert not (tmp_path / "r.h5").exists()


def test_a_failed_replicate_writes_nothing_and_says_what_to_do(tmp_path: Path, monkeypatch) -> None:
    from calibrax.errors import SimulationFailed

    monkeypatch.setenv("CALIBRAX_DOUBLE_FAULT", "fail:0.4")  # every replicate of μs 0.45 fails
    with pytest.raises(SimulationFailed, match="3 of 3 replicates .* failed .*delete it to run them all again"):
        write_pseudo_experiment_resumably(_spec(), "analytic_double", tmp_path / "exp", tmp_path / "r.h5", 3)
    assert not (tmp_path / "exp.yaml").exists()
