"""A store written before the core's refactoring (commit c6375eb, tests/data/store-c6375eb) resumes
with today's code: nothing already stored runs again, the budget's new points run, and the stored
metrics still give the composite model its terms."""

from __future__ import annotations

import shutil
from pathlib import Path

import yaml

from calibrax.core.search.composite import CompositeKriging
from calibrax.core.config import load_config
from calibrax.core.search.points import fit_distance_model
from calibrax.core.running.store import CampaignStore
from tests.conftest import calibrax_cli

OLD = Path(__file__).resolve().parents[1] / "data" / "store-c6375eb"


def test_a_store_from_before_the_refactoring_resumes(tmp_path):
    folder = tmp_path / "old"
    shutil.copytree(OLD, folder)
    campaign = folder / "campaign.yaml"
    before = [(p.id, p.params(), p.metric.value) for p in CampaignStore(folder / "double.h5").points()]
    assert len(before) == 4
    config = yaml.safe_load(campaign.read_text())
    config["budget"]["iterations"] = 1  # the budget may grow on resume
    campaign.write_text(yaml.safe_dump(config, sort_keys=False))
    proc = calibrax_cli("run", str(campaign))
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "resuming campaign" in proc.stderr + proc.stdout
    points = CampaignStore(folder / "double.h5").points()
    assert [(p.id, p.params(), p.metric.value) for p in points[:4]] == before  # nothing re-run
    assert len(points) == 6 and all(p.metric is not None for p in points)
    assert set(points[0].metric.terms()) == {"cohesion", "aif"}  # read back from the old features
    model = fit_distance_model(points, load_config(campaign).surrogate, 0)
    assert isinstance(model, CompositeKriging)


def test_a_store_resumes_from_another_folder_and_through_a_symlink_but_not_with_other_data(tmp_path):
    from tests.conftest import write_double_campaign

    (tmp_path / "a").mkdir()
    first = write_double_campaign(tmp_path / "a", budget={"initial": 3, "iterations": 0})
    assert calibrax_cli("run", str(first)).returncode == 0
    # the same campaign folder reached through a symlink, from another working directory
    (tmp_path / "link").symlink_to(tmp_path / "a", target_is_directory=True)
    config = yaml.safe_load(first.read_text())
    config["budget"]["iterations"] = 1
    (tmp_path / "a" / "campaign.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    proc = calibrax_cli("run", str(tmp_path / "link" / "campaign.yaml"))
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert len(CampaignStore(tmp_path / "a" / "runs/double.h5").points()) == 5
    # the folder copied elsewhere (the experiment's path changes, its data do not)
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    assert calibrax_cli("run", str(tmp_path / "b" / "campaign.yaml"), "--check").returncode == 0
    # the experiment's data changed: refused, and the message says that is why
    exp = tmp_path / "b" / "exp.csv"
    exp.write_text(exp.read_text().replace("9000,", "9100,", 1))
    proc = calibrax_cli("run", str(tmp_path / "b" / "campaign.yaml"), "--check")
    assert proc.returncode == 2 and "the experiment file has changed" in proc.stderr, proc.stderr
