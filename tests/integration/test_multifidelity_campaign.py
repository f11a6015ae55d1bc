"""A campaign across two fidelities of the analytic TEST DOUBLE (``fidelities: [tiny, quick]``):
the double's ``tiny`` cell is biased against its ``quick`` one (C −83 Pa, tan AIF −0.056 at quick,
tests/doubles/analytic_simulator.py), and the pseudo-experiment is made at ``quick``, so the answer
is right only if the model reads the target fidelity through the cheap level's bias."""

from __future__ import annotations

import json
import re
import math

from calibrax import CampaignStore, load_config, run_campaign
from tests.conftest import TRUE_E, TRUE_MU, calibrax_cli, write_double_campaign, write_double_experiment

QUICK_PPD = 12.0


def _campaign(tmp_path, **changes):
    changes = {"fidelities": ["tiny", {"preset": "quick", "initial": 3}], "cell": {},
               "acquisition": {"name": "mfei", "q": 2}, **changes}
    path = write_double_campaign(tmp_path, **changes)
    write_double_experiment(tmp_path / "exp.csv", particles_per_diameter=QUICK_PPD)
    return path


def test_two_fidelity_campaign_recovers_its_truth_at_the_upper_fidelity(tmp_path):
    events = []
    config = load_config(_campaign(tmp_path, budget={"initial": 8, "iterations": 10}))
    summary = run_campaign(config, events.append)
    points = CampaignStore(config.store).points()
    assert len(points) == 8 + 3 + 10 * 2 and summary.failed == 0
    assert [p.fidelity for p in points if p.batch == 0] == ["tiny"] * 8 + ["quick"] * 3
    # nested: the target's initial points are the first of the cheap level's
    for k in range(3):
        assert (points[8 + k].unit == points[k].unit).all()
    assert all(p.acquisition == "mfei" and p.fidelity in ("tiny", "quick") for p in points if p.batch > 0)
    models = CampaignStore(config.store).models()
    # the default model: one AR(1) co-Kriging GP per feature (C, AIF), the distance from them
    assert all(m["kernel"] == "composite_matern52_ard_ar1_fidelity" and set(m["features"]) == {"cohesion", "aif"}
               for m in models.values())
    # the answer at quick: near the truth, which the plausible region holds; tiny's own optimum
    # (μs about 0.08 lower) is not what it names
    rec = summary.answer["params"]
    assert abs(rec["sliding_friction"] - TRUE_MU) < 0.04, rec
    assert abs(math.log10(rec["youngs_modulus"]) - math.log10(TRUE_E)) < 0.2, rec
    lo, hi = summary.answer["ranges"]["sliding_friction"]
    assert lo <= TRUE_MU <= hi
    # the best observed point is one of the target's
    assert next(p for p in points if p.id == summary.best_id).fidelity == "quick"
    # progress says which fidelity each simulation ran at, and the CPU spent per fidelity
    started = [e for e in events if e["event"] == "started"]
    assert {e["fidelity"] for e in started} == {p.fidelity for p in points}
    assert any(" at quick (seed" in e["message"] for e in started)
    done = [e["message"] for e in events if e["event"] == "done"]
    assert "; CPU tiny " in done[-1] and "sims), quick " in done[-1], done[-1]


def test_a_resumed_multifidelity_campaign_repeats_nothing(tmp_path):
    path = _campaign(tmp_path, budget={"initial": 4, "iterations": 1})
    first = calibrax_cli("run", str(path))
    assert first.returncode == 0, first.stderr
    store = CampaignStore(tmp_path / "runs/double.h5")
    before = {p.id: (p.fidelity, [s.seed for s in p.sims], store.result(p.id).provenance.wall_time)
              for p in store.points()}
    assert sorted({f for f, _, _ in before.values()}) == ["quick", "tiny"]
    again = calibrax_cli("run", str(path))
    assert again.returncode == 0, again.stderr
    assert "starts" not in again.stderr  # nothing re-simulated
    # a larger budget runs only the new points; the old ones keep their fidelity, seeds and results
    config = json.loads(json.dumps(__import__("yaml").safe_load(path.read_text())))
    config["budget"]["iterations"] = 2
    path.write_text(__import__("yaml").safe_dump(config))
    more = calibrax_cli("run", str(path))
    assert more.returncode == 0, more.stderr
    after = {p.id: (p.fidelity, [s.seed for s in p.sims], store.result(p.id).provenance.wall_time)
             for p in store.points()}
    assert len(after) == len(before) + 2
    assert {k: after[k] for k in before} == before
    started = [line for line in more.stderr.splitlines() if " starts at " in line]
    assert len(started) == 2 and all(f"point {max(before) + 1}" in s or f"point {max(before) + 2}" in s
                                     for s in started), started
    status = calibrax_cli("status", str(tmp_path / "runs/double.h5"))
    assert status.returncode == 0 and "answer: " in status.stdout
    assert "mfei@tiny" in status.stdout and "the answer and the best observed point are quick's" in status.stdout
    assert re.search(r"tiny \d+ points, [0-9.e+-]+ CPU-s; quick \d+ points", status.stdout), status.stdout
    export = calibrax_cli("export", str(tmp_path / "runs/double.h5"))
    assert export.returncode == 0, export.stderr
    header, *rows = (tmp_path / "runs/double-trials.csv").read_text().splitlines()
    column = header.split(",").index("fidelity")
    assert sorted({r.split(",")[column] for r in rows}) == ["quick", "tiny"]
    report = calibrax_cli("report", str(tmp_path / "runs/double.h5"))
    assert report.returncode == 0, report.stderr
