"""``calibrax diagnose-benchmark``: make (or read) blinded cases, diagnose them, score them."""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np

from calibrax.errors import ConfigError

log = logging.getLogger("calibrax")
LEVELS = ("emulator", "dem")
#: cases per class (per magnitude for a listed effect) when not given
#: cases per class and magnitude: at the emulator level 30 (480 cases, 2.5 min), enough that a size
#: distribution's held-out shrinkage is judged (it shows in the held-out features only at σ = 0.45:
#: 4 counted cases at 10 per class, 15 at 30); at the DEM level 3 (hours)
DEFAULT_PER_CLASS = {"emulator": 30, "dem": 3}


def parse_also(items: list[str] | None) -> dict[str, tuple[str, ...]] | None:
    """``--also BACKEND:CLASS,CLASS`` items to {backend: classes} (None: the default; ``off``: none)."""
    if items is None:
        return None
    if items == ["off"]:
        return {}
    out = {}
    for item in items:
        backend, _, classes = item.partition(":")
        names = tuple(c.strip() for c in classes.split(",") if c.strip())
        if not backend or not names:
            raise ConfigError("--also", f"BACKEND:CLASS[,CLASS…], e.g. liggghts:wall_friction; got {item!r}")
        out[backend] = names
    return out


def run_benchmark(*, level: str = "emulator", model: Path | None = None, design: Path | None = None,
                  per_class: int | None = None, cases: Path | None = None, labels: Path | None = None,
                  answers: Path | None = None, also: list[str] | None = None, seed: int = 0,
                  workers: int | None = None, output: Path | None = None) -> int:
    """The command's body; every input is checked before anything runs or is written."""
    from calibrax.diagnosis.benchmark import scores as sc
    from calibrax.diagnosis.benchmark.cases import read_labels
    from calibrax.diagnosis.benchmark.model import BenchmarkModel

    if level not in LEVELS:
        raise ConfigError("--level", f"one of {list(LEVELS)}, got {level!r}")
    if per_class is not None and per_class < 1:
        raise ConfigError("--per-class", f"must be ≥ 1, got {per_class}")
    if workers is not None and workers < 1:
        raise ConfigError("--workers", f"must be ≥ 1, got {workers}")
    if (cases is None) != (labels is None) and answers is None:
        raise ConfigError("--cases", "an external folder needs both --cases DIR and --labels FILE")
    if answers is not None and labels is None:
        raise ConfigError("--answers", "scoring given answers needs --labels FILE too")
    if cases is not None and not Path(cases).is_dir():
        raise ConfigError("--cases", f"{cases}: no such folder of experiment files")
    bench = BenchmarkModel.load(model)
    other = parse_also(also)
    if other:
        known = set(_classes(bench))
        bad = [c for cs in other.values() for c in cs if c not in known]
        if bad:
            raise ConfigError("--also", f"unknown class(es) {bad}; known: {sorted(known)}")
    given = read_labels(labels) if labels is not None else None
    out = Path(output) if output is not None else Path("runs") / f"diagnose-benchmark-{level}"
    started = time.monotonic()
    if answers is not None:
        found = sc.read_answers(answers)
        level_words, extra = f"answers of {answers}", ""
    else:
        found, given, level_words, extra = _diagnose(level, bench, design, per_class, cases, given, other, seed,
                                                     workers, out)
        out.mkdir(parents=True, exist_ok=True)
        sc.write_answers(found, out / "answers.json")
    out.mkdir(parents=True, exist_ok=True)
    result = sc.score(given, found)
    title = f"Diagnosis benchmark, {level_words}"
    text = sc.table(result, title)
    (out / "scores.md").write_text(text + "\n" + extra + "\n" + _per_case_table(result) + "\n")
    (out / "scores.json").write_text(json.dumps(
        {"level": level, "model": str(bench.source), "classes": result.classes, "verdicts": result.verdicts,
         "confusion": result.confusion.tolist(), "top1": result.top1, "top2": result.top2, "counts": result.counts,
         "top1_by_class": result.top1_by_class, "false_alarms": result.false_alarms, "unlisted_rejected": result.unlisted_rejected,
         "mixed_named": result.mixed_named, "mixed_flagged": result.mixed_flagged, "n_mixed": result.n_mixed,
         "mixed_by_effect": {k: {"named": named, "flagged": flagged, "cases": n}
                             for k, (named, flagged, n) in result.mixed_by_effect.items()},
         "magnitude_error": result.magnitude_error, "shrinkage_ratio": result.shrinkage_ratio,
         "shrinkage_by_class": result.shrinkage_by_class, "shrinkage_counts": result.shrinkage_counts,
         "mismatch": {kind: {k: {"rate": rate, "cases": n} for k, (rate, n) in row.items()}
                      for kind, row in result.mismatch.items()},
         "goals": {name: ok for name, ok in result.goals()}, "cases": result.per_case,
         "wall_time": time.monotonic() - started}, indent=1, default=float))
    sc.confusion_figure(result, out / "confusion.png", title)
    print(text)
    print("written: " + ", ".join(str(out / f) for f in ("scores.md", "scores.json", "confusion.png", "answers.json")
                                  if (out / f).exists()))
    return 0


def _classes(bench) -> list[str]:
    from calibrax.diagnosis.benchmark.cases import CLASS_MIXED, CLASS_NONE, CLASS_UNLISTED
    from calibrax.diagnosis.benchmark.plan import listed_classes

    return [n for n, _ in listed_classes(bench)] + [CLASS_NONE, CLASS_UNLISTED, CLASS_MIXED]


def _diagnose(level, bench, design, per_class, cases, given, other, seed, workers, out):
    """Make or read the cases and diagnose them: (answers, labels, words for the title, more text
    for scores.md)."""
    per_class = per_class or DEFAULT_PER_CLASS[level]
    if level == "emulator":
        return _emulator_level(bench, design, per_class, cases, given, seed, out)
    return _dem_level(bench, per_class, cases, given, other, seed, workers, out)


def _emulator_level(bench, design, per_class, cases, given, seed, out):
    from calibrax.diagnosis.benchmark import emulated as em
    from calibrax.diagnosis.sensitivity import markdown, table_of
    from calibrax.diagnosis.benchmark.cases import write_labels

    rows = em.load_design(design)["rows"]
    truth = em.TruthEmulator.fit(bench, rows)
    progress = _progress_log("diagnose-benchmark")
    if cases is not None:
        experiments = _read_cases(cases, given, bench)
        found = []
        for i, label in enumerate(given):
            rng = np.random.default_rng([seed, 4, i])
            found.append(em.diagnose_emulated(truth, label.case, experiments[label.case], rng, oracle=label))
            progress(i + 1, len(given))
        return found, given, f"emulator level, external cases in {cases}", ""
    labels = em.plan_emulated(bench, per_class, seed, truth)
    out.mkdir(parents=True, exist_ok=True)
    write_labels(labels, out / "labels.yaml")
    found = em.run_emulated(truth, labels, seed, progress=progress)
    blocks = sum(1 for r in rows if r.get("mismatch"))
    words = (f"emulator level ({len(labels)} cases from {truth.n_rows} simulations of "
             f"{Path(design or em.DEFAULT_DESIGN).name}" + (f" and {blocks} of its mismatch blocks" if blocks else "") + ")")
    return found, labels, words, markdown(table_of(truth), "What the shipped model's test can see").split("\n", 2)[2]


def _dem_level(bench, per_class, cases, given, other, seed, workers, out):
    """Real simulations; external cases get no oracle (it would need their truth's simulations)."""
    from calibrax.diagnosis.benchmark import dem
    from calibrax.diagnosis.benchmark.cases import read_labels
    from calibrax.diagnosis.benchmark.plan import plan_dem
    from calibrax.core.registry import get_manager

    def make_executor():
        return get_manager().create("executor", "local", workers=workers or 1)

    if cases is not None:
        files = [Path(cases) / f"{label.case}.yaml" for label in given]
        _read_cases(cases, given, bench)
        executor = make_executor()
        try:
            design_store, _ = dem.run_design(bench, out / "design", executor)
        finally:
            executor.shutdown()
        return (dem.diagnose_cases(bench, files, out, design_store, make_executor), given,
                f"DEM level, external cases in {cases}", "")
    labels_path, found = dem.run_dem_level(bench, plan_dem(bench, per_class, other, seed), out, make_executor,
                                           seed=seed)
    return found, read_labels(labels_path), f"DEM level ({len(found)} cases, diagnosed on {bench.simulator})", ""


def _read_cases(folder: Path, labels, bench) -> dict:
    """Each labelled case's experiment file, read and checked (a missing one names the case)."""
    from calibrax.core.data.experiment import load_experiment
    from calibrax.diagnosis import gap as gaps

    out = {}
    for label in labels:
        path = Path(folder) / f"{label.case}.yaml"
        if not path.is_file():
            raise ConfigError("--cases", f"{path}: the labels name case {label.case!r} but there is no such "
                                         "experiment file (each case is CASE.yaml with its CSVs)")
        out[label.case] = gaps.measured(load_experiment(path), bench.spec.procedure.peak_window)
    return out


def _progress_log(what: str):
    started = time.monotonic()

    def report(done: int, total: int) -> None:
        if done == total or done % 10 == 0:
            log.info("%s: %d of %d cases diagnosed (%.0f s)", what, done, total, time.monotonic() - started)
    return report


def _per_case_table(result) -> str:
    rows = ["| case | class | magnitude | truth | expected | verdict | p | shrinkage | oracle's |", "|---" * 9 + "|"]
    for r in result.per_case:
        rows.append(f"| {r['case']} | {r['class']} | {r['magnitude']} | {r['truth_backend']} | {r['expected']} | "
                    f"{r['verdict']} | "
                    f"{r['p']:.2f} | {r['shrinkage']:.2f} | {r['oracle_shrinkage']:.2f} |")
    return "\n".join(rows)
