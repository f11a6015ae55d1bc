"""``calibrax diagnose`` of a multi-fidelity campaign (``fidelities: [tiny, quick]``) on the
analytic TEST DOUBLE (core machinery only): the design runs at the cheap level, the gap is
measured and the recalibration confirmed at the target, and the emulator reads the target through
the shift between the levels. The double's ``tiny`` cell is biased against its ``quick`` one (C
−83 Pa, tan AIF −0.056, tests/doubles/analytic_simulator.py), and the pseudo-experiment, with a
hidden size distribution (σ_log 0.3: the bulk density 4.5 % higher, the locus unchanged), is made
at ``quick``. Read without the shift, the design's tiny locus would stand against quick's as a gap
of its own, which wall friction or cohesion would be named for.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from calibrax import CampaignStore, ShearCellSpec
from calibrax.diagnosis.design import TARGET_RUNS
from tests.conftest import calibrax_cli, completions_logged, double_env, run_hidden_effect_campaign

NOISE = {"CALIBRAX_DOUBLE_NOISE": "0.03"}
HIDDEN = ("sigma_log", 0.3)


def _with_hidden(spec: ShearCellSpec, value: float) -> ShearCellSpec:
    """``spec`` with the hidden effect at ``value``, as the diagnosis sets it."""
    from calibrax.diagnosis import effects_by_name

    return effects_by_name(["size_distribution"])[0].apply(spec, {HIDDEN[0]: value})


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    """A finished two-fidelity double campaign against a pseudo-experiment made at quick with a
    hidden size distribution."""
    spec = _with_hidden(ShearCellSpec.preset("quick", material={"youngs_modulus": 2e10, "sliding_friction": 0.45}),
                        HIDDEN[1])
    return run_hidden_effect_campaign(tmp_path_factory.mktemp("diagnose-fidelities"), spec, NOISE,
                                      fidelities=["tiny", {"preset": "quick", "initial": 3}], cell={},
                                      acquisition={"name": "mfei", "q": 2}, budget={"initial": 8, "iterations": 6})


def test_the_store_records_the_cheap_cell_outside_the_search_hash(campaign: Path) -> None:
    from calibrax.core.config import search_identity

    store = CampaignStore(campaign)
    cfg = store.config()
    assert set(cfg["fidelity_cells"]) == {"tiny"}
    assert ShearCellSpec.from_dict(cfg["fidelity_cells"]["tiny"]).particles_per_diameter == 9.0
    without = {k: v for k, v in cfg.items() if k != "fidelity_cells"}
    assert search_identity(without, store.experiment()) == search_identity(cfg, store.experiment())


def test_a_two_fidelity_diagnosis_names_the_hidden_effect_at_the_target_and_resumes(campaign: Path) -> None:
    run = calibrax_cli("diagnose", str(campaign), "--budget", "36", env=double_env(**NOISE))
    assert run.returncode == 0, run.stderr
    out = campaign.with_suffix(".diagnosis")
    data = json.loads((out / "diagnosis.json").read_text())
    assert data["verdict"] == "size_distribution", data["reason"]
    lo, hi = data["recalibrated"]["effect_interval"][HIDDEN[0]]
    assert lo < HIDDEN[1] < hi
    # the density's gap, measured at quick, is closed at the recalibration, simulated at quick; the
    # held-out τ curves, which the size distribution leaves alone, stay within the noise
    z = {row["name"]: (row["z"], after["z"]) for row, after in zip(data["before"], data["after"])}
    assert abs(z["bulk_density"][0]) > 3 > abs(z["bulk_density"][1]), z
    assert data["gap_after"] < 3, z
    # the design at tiny but for the target's replicates and the top candidate's point; the
    # confirmation at quick
    by = data["simulations"]["by_fidelity"]
    levelled = [k for k in data["stores"] if k.startswith("level-")]
    assert levelled == ["level-size_distribution"], data["stores"]
    assert by["quick"]["simulations"] == 2 * TARGET_RUNS + 1 and data["simulations"]["confirm"] == TARGET_RUNS
    assert by["tiny"]["simulations"] == data["simulations"]["design"] - TARGET_RUNS - 1
    # the double's size distribution acts alike at both levels; one seed at quick reads its scale
    assert 0.2 < data["level_scale"]["sigma_log"] < 2.0, data["level_scale"]
    assert data["own_signature"] == [], "the double's signature has one shape at both levels: λ carries it"
    assert "By fidelity: tiny " in (out / "diagnosis.md").read_text()
    assert "across fidelities: the design at tiny" in run.stderr
    # the first point, the calibrated one, at quick; the rest at tiny (the effects change the
    # particle count, the size distribution's points among them)
    tiny, quick = (ShearCellSpec.preset(name).particle_count for name in ("tiny", "quick"))

    def counts(store: str) -> list[int]:
        return [r.provenance.particle_count for _, _, r in CampaignStore(out / store).iter_results()]

    # the target's replicates in a store of their own, so a change to the cheap design keeps them
    assert counts(data["stores"]["target"]) == [quick] * TARGET_RUNS
    design = counts(data["stores"]["design"])
    assert quick not in design and design.count(tiny) >= len(design) // 2
    confirm = [r.provenance.particle_count for _, _, r in CampaignStore(next(out.glob("confirm-*.h5"))).iter_results()]
    recalibrated = data["recalibrated"]["effect_values"][HIDDEN[0]]
    at_quick = _with_hidden(ShearCellSpec.preset("quick"), recalibrated).particle_count
    assert confirm == [at_quick] * TARGET_RUNS
    level = [r.provenance.particle_count for _, _, r in CampaignStore(out / data["stores"][levelled[0]]).iter_results()]
    assert level == [_with_hidden(ShearCellSpec.preset("quick"), 0.25).particle_count]

    # run again: everything resumes from the stores, nothing is simulated again
    before = completions_logged(out / "runs")
    again = calibrax_cli("diagnose", str(campaign), "--budget", "36", env=double_env(**NOISE))
    assert again.returncode == 0, again.stderr
    assert completions_logged(out / "runs") == before
    assert json.loads((out / "diagnosis.json").read_text())["verdict"] == "size_distribution"


def test_across_fidelities_no_effect_is_confirmed_at_the_target_before_it_is_answered(tmp_path, monkeypatch) -> None:
    """A plain experiment at quick, diagnosed from a calibrated point whose μs is off: the gap at
    the target is the calibration's, the baseline's refit through the design's emulator closes it,
    and "no effect" is answered only once that refit, simulated at quick, bears it out."""
    from calibrax.core.data.experiment import load_experiment
    from calibrax.core.data.pseudo import write_pseudo_experiment
    from calibrax.core.running.executor import LocalExecutor
    from calibrax.core.search.parameters import ParameterSpace
    from calibrax.diagnosis import Budget, Calibrated, diagnose, effects_by_name
    from calibrax.diagnosis.scoring import NO_EFFECT

    for k, v in NOISE.items():
        monkeypatch.setenv(k, v)
    truth = {"youngs_modulus": 2e10, "sliding_friction": 0.45}
    quick = ShearCellSpec.preset("quick", material=truth)
    experiment = write_pseudo_experiment(quick, "analytic_double", tmp_path / "plain", 3)
    space = ParameterSpace.from_config({"youngs_modulus": {"low": 5e9, "high": 5e10, "log": True},
                                        "sliding_friction": {"low": 0.1, "high": 0.9}})
    off = {"youngs_modulus": 2e10, "sliding_friction": 0.55}
    calibrated = Calibrated("analytic_double", quick, space, load_experiment(experiment), off,
                            {"youngs_modulus": (1e10, 4e10), "sliding_friction": (0.4, 0.7)}, target="quick",
                            cheap=("tiny", ShearCellSpec.preset("tiny", material=truth)))
    d = diagnose(calibrated, effects_by_name(), tmp_path / "plain.diagnosis", LocalExecutor(1),
                 budget=Budget.across_fidelities())
    assert d.verdict == NO_EFFECT, d.reason
    assert any(abs(g.z) > 3 for g in d.before), "the calibrated point's μs should open a gap at quick"
    (refit,) = d.final.confirmations
    assert refit.effect == NO_EFFECT and refit.confirmed, refit.words()
    assert abs(d.recalibrated["params"]["sliding_friction"] - truth["sliding_friction"]) < 0.05, d.recalibrated
    assert "at the target" in d.reason
    quick_count = ShearCellSpec.preset("quick").particle_count
    assert [r.provenance.particle_count for _, _, r in CampaignStore(tmp_path / "plain.diagnosis" / d.stores["confirm"])
            .iter_results()] == [quick_count] * TARGET_RUNS
    # "no effect" settled at the target: no candidate's point there is spent
    assert not [k for k in d.stores if k.startswith("level-")], d.stores
    assert d.simulations["by_fidelity"]["quick"]["simulations"] == 2 * TARGET_RUNS
