"""Property: any campaign file — random YAML, or a valid one mutated at random — given to
`calibrax run --check` ends in exit 0 or a ConfigError with exit 2, never a traceback."""

from __future__ import annotations

import copy
import math

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from calibrax.cli import main
from tests.conftest import write_double_campaign

SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12), st.floats(allow_nan=True),
                    st.text(max_size=12), st.just(math.inf), st.just(-1), st.just(0), st.just(0.5), st.just("qei"),
                    st.just("local"), st.just("tiny"), st.just("../../etc/passwd"), st.just("$(rm -rf /)"))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                        st.dictionaries(st.text(max_size=8), inner, max_size=3)),
                      max_leaves=6)
KEYS = ["name", "simulator", "experiment", "cell", "material", "parameters", "metric", "acquisition", "budget",
        "executor", "store", "workdir", "seed", "seeds_per_point", "colour", "preset", "low", "high", "log", "q",
        "youngs_modulus", "sliding_friction", "numerics", "geometry", "procedure", "dt_fraction", "workers",
        "timeout_s", "initial", "iterations", "batching", "cluster", "radius", "poisson_ratio", "size_distribution"]


def paths(tree, prefix=()):
    """Every (path to a mapping, key) in a nested mapping."""
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield prefix, k
            yield from paths(v, prefix + (k,))


@st.composite
def mutated(draw, base):
    config = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 4))):
        sites = list(paths(config))
        if not sites:
            break
        where, key = draw(st.sampled_from(sites))
        node = config
        for part in where:
            node = node[part]
        action = draw(st.sampled_from(["delete", "replace", "add", "rename"]))
        if action == "delete":
            node.pop(key, None)
        elif action == "replace":
            node[key] = draw(VALUES)
        elif action == "add":
            node[draw(st.sampled_from(KEYS))] = draw(VALUES)
        else:
            node[draw(st.sampled_from(KEYS))] = node.pop(key)
    return config


@pytest.fixture(scope="module")
def base_config(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz")
    path = write_double_campaign(folder, executor={"name": "local", "workers": 2})
    return folder, yaml.safe_load(path.read_text())


def check_exit(folder, text, capsys):
    path = folder / "campaign.yaml"
    path.write_text(text)
    code = main(["run", str(path), "--check"])
    err = capsys.readouterr().err
    assert code in (0, 2), (code, text, err)
    if code == 2:
        assert err.startswith("calibrax: error: ") and "Traceback" not in err
    assert not (folder / "runs").exists()


@settings(max_examples=1500, derandomize=True, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_mutated_campaign_files(base_config, capsys, data):
    folder, base = base_config
    config = data.draw(mutated(base))
    check_exit(folder, yaml.safe_dump(config, allow_unicode=True), capsys)


@settings(max_examples=500, derandomize=True, deadline=None, suppress_health_check=list(HealthCheck))
@given(text=st.one_of(st.text(max_size=200), st.binary(max_size=120).map(lambda b: b.decode("latin-1")),
                      VALUES.map(lambda v: yaml.safe_dump(v, allow_unicode=True))))
def test_random_text_as_campaign_file(base_config, capsys, text):
    folder, _ = base_config
    check_exit(folder, text, capsys)
