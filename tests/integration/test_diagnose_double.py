"""``calibrax diagnose`` as a user runs it, on the analytic TEST DOUBLE (core machinery only: the
command line, the stores, resume, the report, bad input). The double's effects are known
functions with seed noise (tests/doubles/analytic_simulator.py); the physics is tested on
numba_dem in test_diagnose_numba_dem.py.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from calibrax import ShearCellSpec
from tests.browser import page_images
from tests.conftest import calibrax_cli, completions_logged, double_env, run_hidden_effect_campaign

NOISE = {"CALIBRAX_DOUBLE_NOISE": "0.03"}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory, request) -> Path:
    """A finished double campaign against a pseudo-experiment made with wall friction 0.3."""
    spec = ShearCellSpec.preset("tiny", material={"youngs_modulus": 2e10, "sliding_friction": 0.45},
                                geometry={"wall_friction": 0.3})
    return run_hidden_effect_campaign(tmp_path_factory.mktemp("diagnose-double"), spec, NOISE)


def test_diagnose_names_the_hidden_wall_friction_and_writes_everything(campaign: Path) -> None:
    run = calibrax_cli("diagnose", str(campaign), "--budget", "30", env=double_env(**NOISE))
    assert run.returncode == 0, run.stderr
    out = campaign.with_suffix(".diagnosis")
    data = json.loads((out / "diagnosis.json").read_text())
    assert data["verdict"] == "wall_friction", data["reason"]
    assert "Lateral wall friction explains the gap" in run.stdout
    lo, hi = data["recalibrated"]["effect_interval"]["wall_friction"]
    assert lo < 0.3 < hi
    assert abs(data["recalibrated"]["params"]["sliding_friction"] - 0.45) < 0.08   # posterior mean: 0.50
    assert {k: v for k, v in data["simulations"].items() if k not in ("engine_seconds", "cpu_seconds")} == {"design": 26, "design_failed": 0, "confirm": 4, "total": 30}
    for name in ("diagnosis.md", "diagnosis_residuals.png", "diagnosis_scores.png", "diagnosis_curves.png"):
        assert (out / name).is_file(), name
    assert len(list(out.glob("design-*.h5"))) == 1 and len(list(out.glob("confirm-*.h5"))) == 1
    # progress says how many are done and to go, and which engine ran which seed
    assert "diagnose design: 26 of 26 simulations done, 0 to go" in run.stderr
    assert "on analytic_double, seed 700000000" in run.stderr

    # run again: everything resumes from the stores, nothing is simulated again
    before = completions_logged(out / "runs")
    again = calibrax_cli("diagnose", str(campaign), "--budget", "30", env=double_env(**NOISE))
    assert again.returncode == 0, again.stderr
    assert completions_logged(out / "runs") == before
    assert json.loads((out / "diagnosis.json").read_text())["verdict"] == "wall_friction"

    # another --fit-on reuses the design and confirms its own recalibration in a store of its own
    other = calibrax_cli("diagnose", str(campaign), "--budget", "30", "--fit-on", "locus", env=double_env(**NOISE))
    assert other.returncode == 0, other.stderr
    assert completions_logged(out / "runs") == before + 4
    assert len(list(out.glob("confirm-*.h5"))) == 2

    # the campaign's report includes the diagnosis
    report = calibrax_cli("report", str(campaign))
    assert report.returncode == 0, report.stderr
    page = (campaign.with_suffix(".report") / "index.html").read_text()
    assert "Diagnosis of the sim-to-real gap" in page and "diagnosis_residuals.png" in page
    # and so does the single file, its figures embedded and shown by a real browser
    single = calibrax_cli("report", str(campaign), "--single-file", "-o", str(campaign.parent / "mailed.html"))
    assert single.returncode == 0, single.stderr
    images = page_images(campaign.parent / "mailed.html")
    assert {"diagnosis_residuals", "diagnosis_scores", "diagnosis_curves"} <= {i["alt"] for i in images}, images
    assert all(i["scheme"] == "data" and i["width"] > 100 for i in images), images


@pytest.mark.parametrize("args, key", [
    (["--effects", "wall_friction,bogus"], "--effects"),
    (["--budget", "5"], "--budget"),
    (["--fit-on", "locus,density,compressibility,flow,shape"], "--fit-on"),
    (["--fit-on", "curves"], "--fit-on"),
    (["--backend", "nonesuch"], "--backend"),
    (["--workers", "0"], "--workers"),
    (["--backend", "yade", "--effects", "cohesion"], "yade cannot model cohesion"),
])
def test_bad_input_names_the_option_and_runs_nothing(campaign: Path, tmp_path: Path, args: list[str], key: str) -> None:
    out = tmp_path / "never"
    run = calibrax_cli("diagnose", str(campaign), "-o", str(out), *args)
    assert run.returncode == 2, run.stderr
    assert key in run.stderr
    assert not out.exists()


def test_a_store_that_does_not_exist_is_named(tmp_path: Path) -> None:
    run = calibrax_cli("diagnose", str(tmp_path / "missing.h5"))
    assert run.returncode == 2
    assert "missing.h5" in run.stderr


def test_an_experiment_with_peaks_only_is_diagnosed_on_the_yield_locus(tmp_path: Path) -> None:
    """No curves, no density: the locus alone ranks the candidates, and with nothing held out no
    recalibration is run (the summary says why)."""
    from tests.conftest import write_double_campaign

    cfg = write_double_campaign(tmp_path, metric="c_aif", budget={"initial": 4, "iterations": 1})
    assert calibrax_cli("run", str(cfg), "-q", env=double_env(**NOISE)).returncode == 0
    store = tmp_path / "runs" / "double.h5"
    run = calibrax_cli("diagnose", str(store), "--budget", "18", "--effects", "wall_friction,cohesion",
                       env=double_env(**NOISE))
    assert run.returncode == 0, run.stderr
    data = json.loads((store.with_suffix(".diagnosis") / "diagnosis.json").read_text())
    assert set(data["features"]) == {"peak_ratio_9kPa", "peak_ratio_8kPa", "peak_ratio_7kPa", "peak_ratio_6kPa"}
    assert data["judge_on"] == [] and data["simulations"]["confirm"] == 0
    assert "none is left to judge it on" in run.stdout
    # the log does not promise confirmation simulations that never run (issue 36)
    assert "then 3 to confirm" not in run.stdout + run.stderr and "up to 3 to confirm" in run.stdout + run.stderr


def test_sensitivity_tables_what_the_test_can_see_and_resumes(campaign: Path) -> None:
    """`calibrax sensitivity STORE` (issue 34): the diagnosis design around the campaign's answer,
    each feature's shift per parameter step and per effect in noise units; the double's wall
    friction and cohesion move the locus, its size distribution only the density."""
    run = calibrax_cli("sensitivity", str(campaign), "--workers", "2", env=double_env(**NOISE))
    assert run.returncode == 0, run.stderr
    out = campaign.with_suffix(".sensitivity")
    for name in ("sensitivity.md", "sensitivity.json", "sensitivity.png", "sensitivity.svg"):
        assert (out / name).is_file(), name
    table = json.loads((out / "sensitivity.json").read_text())
    assert table["replicates"] == 3 and table["n_simulations"] == 32  # 4 replicates, 4 baseline, 8 per effect
    assert sorted(c.split(" ")[0] for c in table["columns"][:2]) == ["E", "μs"]

    def visible(effect: str, group: str) -> float:
        j = table["columns"].index(next(c for c in table["columns"] if c.startswith(f"{effect} medium")))
        return max(abs(table["z"][i][j]) for i, g in enumerate(table["groups"]) if g == group)

    assert visible("wall_friction", "locus") >= 3 and visible("cohesion", "locus") >= 3
    assert visible("size_distribution", "density") >= 3 and visible("size_distribution", "locus") < 3
    assert "| wall_friction medium" in run.stdout and "**" in run.stdout
    # run again: the design resumes from its store, nothing is simulated again
    before = completions_logged(out / "design")
    again = calibrax_cli("sensitivity", str(campaign), env=double_env(**NOISE))
    assert again.returncode == 0, again.stderr
    assert completions_logged(out / "design") == before


@pytest.mark.parametrize("args, key", [(["--replicates", "0"], "--replicates"), (["--workers", "0"], "--workers"),
                                       (["nowhere.h5"], "nowhere.h5")])
def test_sensitivity_bad_input_names_it(args: list[str], key: str, tmp_path: Path) -> None:
    run = calibrax_cli("sensitivity", *args, "-o", str(tmp_path / "never"))
    assert run.returncode == 2 and key in run.stderr, run.stderr
    assert not (tmp_path / "never").exists()
