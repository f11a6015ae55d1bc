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
