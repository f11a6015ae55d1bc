"""Every bundled campaign file loads and validates: an example a user copies must not exit 2."""

from pathlib import Path

import pytest

from calibrax.core.config import load_config

EXAMPLES = sorted((Path(__file__).resolve().parents[2] / "examples").glob("*.yaml"))


def test_there_are_examples():
    assert len(EXAMPLES) >= 5


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_campaign_loads(path):
    config = load_config(path)
    assert config.spec.particle_count > 0


EXPERIMENTS = sorted((Path(__file__).resolve().parents[2] / "examples" / "data").glob("*.yaml"))


@pytest.mark.parametrize("path", EXPERIMENTS, ids=[p.name for p in EXPERIMENTS])
def test_every_bundled_experiment_was_made_by_its_presets_cell_as_it_resolves_now(path):
    """A preset changed under a bundled pseudo-experiment (the converged rim gap did) makes it the
    old cell's data: remake it (examples/make_pseudo_experiment.py), don't let it drift."""
    from calibrax.core.data.experiment import load_experiment

    experiment = load_experiment(path)
    assert experiment.source.startswith("PSEUDO-EXPERIMENT, NOT MEASURED DATA.")
    assert experiment.stale_cell == (), "\n".join(experiment.stale_cell)
