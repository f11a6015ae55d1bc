"""A campaign calibrates any declared field of the cell by its dotted path (``geometry.wall_friction``,
``material.rolling_friction``), the path the diagnosis's effects set: on the analytic TEST DOUBLE
(the whole search, against a pseudo-experiment made at a known wall and rolling friction), and on
numba_dem ``tiny`` (one short real run: the values reach the engine)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from calibrax import CampaignStore, load_config, run_campaign
from calibrax.core.search.parameters import DISPLAY
from calibrax.diagnosis.effects import WallFriction
from tests.conftest import ROOT, TRUE_E, TRUE_MU, calibrax_cli, write_double_campaign
from tests.doubles.analytic_simulator import ROLLING_SLOPE, true_locus

#: the hidden truth of the pseudo-experiment: the cell's wall friction and the particles' μr
TRUE_WALL, TRUE_ROLLING = 0.2, 0.3
DOTTED = {"geometry.wall_friction": {"low": 0.0, "high": 0.5},
          "material.rolling_friction": {"low": 0.1, "high": 0.9}}


def double_peak(sigma: float, wall: float, rolling: float) -> float:
    """The double's peak τ, Pa, at ``sigma`` (Pa) in the tiny cell with the truth's E and μs."""
    c, aif = true_locus(TRUE_E, TRUE_MU)
    return (c + sigma * (math.tan(math.radians(aif)) + ROLLING_SLOPE * (rolling - 0.5))) * (1.0 + 0.8 * wall)


def write_experiment(path) -> None:
    """Three replicates of the double's locus at the hidden truth, with a small known scatter."""
    lines = ["# pseudo-experiment from the analytic TEST DOUBLE at wall friction 0.2, mu_r 0.3",
             "normal_stress_pa,peak_shear_stress_pa,replicate"]
    for rep, scale in ((1, 1.0), (2, 1.01), (3, 0.99)):
        lines += [f"{s:.0f},{scale * double_peak(s, TRUE_WALL, TRUE_ROLLING):.3f},{rep}"
                  for s in (9000.0, 8000.0, 7000.0, 6000.0)]
    path.write_text("\n".join(lines) + "\n")


def test_a_campaign_calibrates_wall_and_rolling_friction_by_their_paths(tmp_path):
    path = write_double_campaign(tmp_path, parameters=DOTTED, budget={"initial": 6, "iterations": 6},
                                 material={"youngs_modulus": TRUE_E, "sliding_friction": TRUE_MU})
    write_experiment(tmp_path / "exp.csv")
    summary = run_campaign(load_config(path))
    store = CampaignStore(tmp_path / "runs" / "double.h5")
    points = store.points()
    assert len(points) == 6 + 6 * 2 and summary.failed == 0
    ratios = []  # each point's values reached the simulator at their paths: its peaks are the double's
    for p in points:  # there, up to one factor (the running mean the peak is read from) common to all
        wall, rolling = p.params()["geometry.wall_friction"], p.params()["material.rolling_friction"]
        peaks = store.result(p.id).peak_shear_stress
        ratios += list(peaks / [double_peak(s, wall, rolling) for s in (9e3, 8e3, 7e3, 6e3)])
    np.testing.assert_allclose(ratios, ratios[0], rtol=1e-9)
    assert 0.99 < ratios[0] <= 1.0
    rec, ranges = summary.answer["params"], summary.answer["ranges"]
    assert abs(rec["geometry.wall_friction"] - TRUE_WALL) < 0.05, rec
    assert abs(rec["material.rolling_friction"] - TRUE_ROLLING) < 0.1, rec
    for name, truth in (("geometry.wall_friction", TRUE_WALL), ("material.rolling_friction", TRUE_ROLLING)):
        assert ranges[name][0] <= truth <= ranges[name][1], ranges
    # the answer speaks the declared symbols; the diagnosis's wall-friction effect sets the same path
    assert (DISPLAY["geometry.wall_friction"][0], DISPLAY["material.rolling_friction"][0]) == ("μw", "μr")
    assert WallFriction.parameters[0].path in DOTTED
    status = calibrax_cli("status", str(store.path))
    assert status.returncode == 0 and "geometry.wall_friction" in status.stdout, status.stderr


def test_a_backend_without_the_capability_is_refused_before_anything_runs(tmp_path):
    """``--check`` on a campaign that calibrates the Bond number on YADE, which does not model
    cohesion: exit 2 naming the parameter and the capability its declaration gives."""
    path = write_double_campaign(tmp_path, parameters={"material.bond_number": {"low": 0.1, "high": 1.0},
                                                       "sliding_friction": {"low": 0.1, "high": 0.9}},
                                 simulator="yade")
    proc = calibrax_cli("run", str(path), "--check")
    assert proc.returncode == 2, proc.stderr
    assert "parameters.material.bond_number: yade cannot model 'cohesion'" in proc.stderr, proc.stderr


@pytest.mark.slow
@pytest.mark.numba_dem
def test_numba_dem_tiny_takes_the_dotted_values(tmp_path):
    """One short real numba_dem run per point: the wall friction reaches the engine (its provenance
    carries the spec hash of the cell with the point's values)."""
    from calibrax.core.sheartest import ShearCellSpec

    config = {"name": "dotted", "simulator": "numba_dem",
              "experiment": str(ROOT / "examples/data/pseudo-numba-tiny-points.csv"),
              "cell": {"preset": "tiny", "procedure": {"preset": "paper", "preshear_rotation": 0.06,
                                                        "preshear_max_rotation": None, "shear_rotation": 0.06}},
              "parameters": DOTTED, "budget": {"initial": 2, "iterations": 0},
              "executor": {"name": "local", "workers": 2}, "store": "dotted.h5", "seed": 5}
    path = tmp_path / "campaign.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    loaded = load_config(path)
    summary = run_campaign(loaded)
    assert summary.failed == 0
    store = CampaignStore(loaded.store)
    for p in store.points():
        params = p.params()
        result = store.result(p.id)
        expected = loaded.spec.with_values(params).replace(numerics={"seed": result.provenance.seed})
        assert result.provenance.spec_hash == expected.spec_hash()
        assert expected.geometry.wall_friction == params["geometry.wall_friction"] > 0
        assert result.provenance.backend == "numba_dem" and np.all(np.isfinite(result.peak_shear_stress))
    assert isinstance(loaded.spec, ShearCellSpec)
