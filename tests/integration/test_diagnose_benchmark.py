"""``calibrax diagnose-benchmark``: the emulator level on a handful of cases, external cases, the
scoring's bookkeeping against the labels, bad input; and blinded case files from real engines.

The emulator level's truth is a response surface of the shipped DEM design (real numba_dem
simulations, see its ``about``), not a test double of the core.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from calibrax.cli import main
from calibrax.diagnosis.benchmark.cases import MeasurementNoise, cell_words, read_labels, write_blinded
from calibrax.diagnosis.benchmark.scores import read_answers, score
from tests.bank import JOBS, declare_smoke

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "data"
#: any real result will do for a blinded file: the engines' smoke tests (shared with their modules)
NUMBA = declare_smoke("numba_dem")
LIGGGHTS = declare_smoke("liggghts")


@pytest.fixture(scope="module")
def emulated(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "emulator"
    assert main(["diagnose-benchmark", "--per-class", "1", "--seed", "3", "-o", str(out)]) == 0
    return out


def test_every_case_is_labelled_answered_and_counted(emulated):
    labels = read_labels(emulated / "labels.yaml")
    answers = read_answers(emulated / "answers.json")
    # one case per magnitude of each of the three candidates, three controls, two of an unlisted
    # effect alone and two of a listed and an unlisted one together; per procedure mismatch of the
    # shipped design (five), one case of it alone and one with a listed effect on top
    assert len(labels) == 26 and sorted(a.case for a in answers) == sorted(lab.case for lab in labels)
    assert sorted(lab.klass for lab in labels).count("none") == 3
    scores = json.loads((emulated / "scores.json").read_text())
    confusion = np.array(scores["confusion"])
    assert confusion.sum() == 26
    rows = dict(zip(scores["classes"], confusion.sum(axis=1)))
    assert rows == {"cohesion": 3, "size_distribution": 3, "wall_friction": 3, "none": 3, "unlisted": 2,
                    "listed+unlisted": 2, "mismatch": 5, "mismatch+listed": 5}
    assert {lab.mismatch for lab in labels if lab.klass.startswith("mismatch")} == {
        "fixed_preshear", "slow_rate", "fast_rate", "inertial_rate", "liggghts"}
    # the eight-times rate is beyond the noise, the former fixed preshear inside it
    expected = {lab.mismatch: lab.expected for lab in labels if lab.klass == "mismatch"}
    assert expected["inertial_rate"] == "none of the candidates" and expected["fixed_preshear"] == "none"
    md = (emulated / "scores.md").read_text()
    assert scores["n_mixed"] == 2 and "| listed + unlisted: the listed one named |" in md
    assert "| mismatch, all: a listed effect named (false alarm) |" in md
    # the confusion matrix is what the labels and answers say, case by case
    by_case = {a.case: a.verdict for a in answers}
    for lab in labels:
        assert confusion[scores["classes"].index(lab.klass), scores["verdicts"].index(by_case[lab.case])] >= 1
    assert (emulated / "confusion.png").stat().st_size > 1000
    assert "| top-1, medium+large |" in (emulated / "scores.md").read_text()


def test_answers_rescore_to_the_same_scores(emulated, tmp_path):
    again = tmp_path / "again"
    assert main(["diagnose-benchmark", "--labels", str(emulated / "labels.yaml"), "--answers",
                 str(emulated / "answers.json"), "-o", str(again)]) == 0
    first = json.loads((emulated / "scores.json").read_text())
    second = json.loads((again / "scores.json").read_text())
    assert first["confusion"] == second["confusion"] and first["top1"] == second["top1"]


def test_external_cases_are_read_from_their_files(tmp_path):
    cases = tmp_path / "cases"
    cases.mkdir()
    for name in ("pseudo-numba-tiny.yaml", "pseudo-numba-tiny-points.csv", "pseudo-numba-tiny-curves.csv"):
        shutil.copy(EXAMPLE / name, cases / name)
    # the bundled pseudo-experiment: numba_dem tiny at E = 20 GPa, μs = 0.35, no effect
    labels = tmp_path / "labels.yaml"
    labels.write_text(yaml.safe_dump({"cases": [{"case": "pseudo-numba-tiny", "class": "none", "expected": "none"}]}))
    out = tmp_path / "out"
    assert main(["diagnose-benchmark", "--cases", str(cases), "--labels", str(labels), "-o", str(out)]) == 0
    (answer,) = read_answers(out / "answers.json")
    assert answer.case == "pseudo-numba-tiny" and answer.verdict in answer.ranked + ("none of the candidates",)
    assert json.loads((out / "scores.json").read_text())["confusion"] == score(read_labels(labels), [answer]).confusion.tolist()


@pytest.mark.parametrize("args, key", [
    (["--cases", "{tmp}"], "--cases"),
    (["--answers", "{tmp}/a.json"], "--answers"),
    (["--per-class", "0"], "--per-class"),
    (["--also", "liggghts"], "--also"),
    (["--also", "liggghts:shape"], "--also"),
    (["--model", "{tmp}/missing.yaml"], "missing.yaml"),
])
def test_bad_input_exits_2_naming_it(tmp_path, capsys, args, key):
    argv = ["diagnose-benchmark", "-o", str(tmp_path / "out")] + [a.format(tmp=tmp_path) for a in args]
    assert main(argv) == 2
    assert key in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_labels_naming_a_missing_case_exit_2(tmp_path, capsys):
    (tmp_path / "cases").mkdir()
    labels = tmp_path / "labels.yaml"
    labels.write_text(yaml.safe_dump({"cases": [{"case": "c1", "class": "none", "expected": "none"}]}))
    assert main(["diagnose-benchmark", "--cases", str(tmp_path / "cases"), "--labels", str(labels),
                 "-o", str(tmp_path / "out")]) == 2
    assert "c1" in capsys.readouterr().err


@pytest.mark.parametrize("job", [pytest.param(NUMBA, marks=pytest.mark.bank(NUMBA)),
                                 pytest.param(LIGGGHTS, marks=pytest.mark.bank(LIGGGHTS))])
def test_blinded_files_read_back_and_tell_nothing(bank, tmp_path, job):
    """A case written blind from a real engine's result is an ordinary experiment whose header names
    the cell but not the backend, the material or the walls' friction; the noise is on top."""
    from calibrax.core.data.experiment import load_experiment
    from calibrax.diagnosis import gap as gaps

    result, spec = bank.result(job), JOBS[job].spec
    path = write_blinded([result, result], tmp_path / "case-001", cell_words(spec), MeasurementNoise(),
                         np.random.default_rng(0))
    text = "".join(p.read_text() for p in tmp_path.glob("case-001*"))
    for word in ("numba", "liggghts", "LIGGGHTS", "material", "wall_friction", "sliding_friction", "cohesion"):
        assert word not in text
    experiment = load_experiment(path)
    features = gaps.measured(experiment, spec.procedure.peak_window)
    assert len(features) == 2 and {"peak_ratio_9kPa", "bulk_density", "initial_slope"} <= set(features[0])
    # the same result twice, with independent measurement noise: the replicates differ by a few per cent
    a, b = features[0]["peak_ratio_9kPa"], features[1]["peak_ratio_9kPa"]
    assert a != b and abs(a - b) / a < 0.2
