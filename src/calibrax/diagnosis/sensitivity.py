"""``calibrax sensitivity``: what a test can see, before a user buys simulations for a diagnosis.

For a calibrated point (a campaign store's answer, or a model file as the blind benchmark's) the
diagnosis's own DEM design is run around it (resumable, :func:`calibrax.diagnosis.benchmark.design.run_design`:
replicates at the point, Sobol points over its plausible region, each candidate effect over its
range) and a response surface is fitted to it (:class:`~calibrax.diagnosis.benchmark.emulated.TruthEmulator`:
each feature quadratic in the calibrated parameters, each effect and their products, one
simulation's seed noise from the residuals of the points without an effect, the replicates and
the baseline: an effect's lack of fit is not the test's noise). From the surface, per feature:

- its value at the point and one simulation's seed s.d.;
- its shift for a step of 10 % of each calibrated parameter's searched range (log-scaled where
  the search is), and for each candidate effect at its small, medium and large magnitude;

every shift in noise units of an n-replicate mean (the seed s.d. over √n: an experiment of n
replicates against a well-averaged simulation). A shift of 3 units is what a diagnosis needs to
see an effect at all; the features an experiment carries decide which rows count: ``locus`` needs
only the shear peaks, ``density`` the bulk density, ``flow`` the preshear values or curves,
``shape`` the τ curves. The ``mean peak τ/σ`` row is the four steps' mean (the robust metric's
feature), its noise from the steps' covariance.

The blind benchmark's detectability table is this command's table on its shipped model and design
(``calibrax sensitivity`` with no argument: nothing is simulated).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from calibrax.diagnosis import gap as gaps

#: the step of each calibrated parameter: this fraction of its searched range (unit cube)
PARAMETER_STEP = 0.1
#: a shift of this many noise units is what a diagnosis can see
VISIBLE = 3.0
MEAN_PEAK = "peak_ratio (mean of steps)"


@dataclass
class Sensitivity:
    """The table: ``rows`` (feature names) × ``columns`` (what moves them), ``z`` the shifts in
    noise units of a ``replicates``-replicate mean, shape (rows, columns); ``value`` and ``seed_sd``
    per row; ``groups`` per row (what the experiment must carry); ``n_simulations`` behind it."""

    rows: list[str]
    groups: list[str]
    columns: list[str]
    kinds: list[str]                 # per column: "parameter" or "effect"
    value: list[float]
    seed_sd: list[float]
    z: list[list[float]]
    replicates: int
    n_simulations: int
    point: dict[str, float]

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _combinations(features: tuple[str, ...]) -> tuple[list[str], list[str], np.ndarray]:
    """Every feature, and the mean of the locus's steps: names, groups and the matrix L (rows, F)."""
    rows = list(features) + [MEAN_PEAK]
    groups = [gaps.group_of(n) for n in features] + ["locus"]
    weights = np.vstack([np.eye(len(features)), np.zeros((1, len(features)))])
    locus = [i for i, n in enumerate(features) if gaps.group_of(n) == "locus"]
    weights[-1, locus] = 1.0 / len(locus)
    return rows, groups, weights


def _parameter_steps(model) -> list[tuple[str, dict[str, float]]]:
    """(label, point) of a step of :data:`PARAMETER_STEP` of each calibrated parameter's range from
    the model's point, up unless that leaves the design's box."""
    from calibrax.core.search.parameters import DISPLAY

    space, box = model.space, model.box()
    centre = np.array([[model.centre[n] for n in space.names]])
    out = []
    for i, name in enumerate(space.names):
        unit = space.to_unit(centre)
        up = unit.copy()
        up[0, i] += PARAMETER_STEP
        if space.from_unit(np.clip(up, 0, 1))[0, i] > box.high[i] + 1e-12 or up[0, i] > 1.0:
            up[0, i] -= 2 * PARAMETER_STEP
        moved = float(space.from_unit(np.clip(up, 0, 1))[0, i])
        symbol, scale, unit_name = DISPLAY.get(name, (name, 1.0, ""))
        was = model.centre[name]
        label = (f"{symbol} ×{moved / was:.2f}" if space.parameters[i].log
                 else f"{symbol} {moved - was:+.3g}{(' ' + unit_name) if unit_name else ''}")
        out.append((label, {**model.centre, name: moved}))
    return out


def _effect_levels(model) -> list[tuple[str, dict[str, float]]]:
    """(label, effects) of each candidate effect at its benchmark magnitudes (small, medium, large;
    a plugin's effect without them at a quarter, half and the whole of its range)."""
    from calibrax.diagnosis.benchmark.cases import MAGNITUDES

    out = []
    for effect in model.effects():
        p = effect.parameters[0]
        levels = MAGNITUDES.get(p.name) or {lvl: p.off + f * (p.high - p.off)
                                            for lvl, f in (("small", 0.25), ("medium", 0.5), ("large", 1.0))}
        out += [(f"{effect.name} {lvl} ({p.name} = {v:g})", {p.name: v}) for lvl, v in levels.items()]
    return out


def sensitivity(model, rows: list[dict[str, Any]], replicates: int = 3, unlisted: bool = False) -> Sensitivity:
    """The table of a design's ``rows`` (as :func:`~calibrax.diagnosis.benchmark.emulated.export_design`
    writes them) around ``model``'s point; ``unlisted``: the rows include the rolling-friction block."""
    from calibrax.diagnosis.benchmark.emulated import TruthEmulator

    return table_of(TruthEmulator.fit(model, rows, unlisted=unlisted), replicates)


def table_of(truth, replicates: int = 3) -> Sensitivity:
    """The table of a fitted :class:`~calibrax.diagnosis.benchmark.emulated.TruthEmulator` at its model's point."""
    model = truth.model
    names, groups, weights = _combinations(truth.features)
    cov = truth.plain_cov if truth.plain_cov is not None else truth.cov
    sd = np.sqrt(np.diag(weights @ cov @ weights.T))
    noise = sd / math.sqrt(replicates)
    base = weights @ truth.mean(model.centre, {})
    columns, kinds, z = [], [], []
    for label, point in _parameter_steps(model):
        columns.append(label), kinds.append("parameter")
        z.append((weights @ truth.mean(point, {}) - base) / noise)
    for label, effects in _effect_levels(model):
        columns.append(label), kinds.append("effect")
        z.append((weights @ truth.mean(model.centre, effects) - base) / noise)
    zt = np.array(z).T
    return Sensitivity(names, groups, columns, kinds, [float(v) for v in base], [float(v) for v in sd],
                       [[float(v) for v in row] for row in zt], replicates, truth.n_rows, dict(model.centre))


def markdown(table: Sensitivity, title: str) -> str:
    """The table as Markdown: one row per feature, one column per step or effect; shifts of at
    least :data:`VISIBLE` noise units in bold; then, per effect, whether any feature sees it."""
    lines = [f"# {title}", "",
             f"Shift of each feature, in noise units of a {table.replicates}-replicate mean (one simulation's seed "
             f"s.d. / √{table.replicates}), for a step of {PARAMETER_STEP:.0%} of each calibrated parameter's range "
             f"and for each candidate effect, at {', '.join(f'{k} = {v:.4g}' for k, v in table.point.items())}; "
             f"from a response surface of {table.n_simulations} simulations. **Bold**: |shift| ≥ {VISIBLE:g}, what a "
             "diagnosis can see. Group: what the experiment must carry (locus: the shear peaks; density: the bulk "
             "density or the CBD; compressibility: the compressibility ramp; flow: preshear values or curves; shape: τ curves).", "",
             "| feature | group | value | seed s.d. | " + " | ".join(table.columns) + " |",
             "|---|---|---|---|" + "---|" * len(table.columns)]
    for i, name in enumerate(table.rows):
        cells = [f"**{v:+.1f}**" if abs(v) >= VISIBLE else f"{v:+.1f}" for v in table.z[i]]
        lines.append(f"| {name} | {table.groups[i]} | {table.value[i]:.4g} | {table.seed_sd[i]:.3g} | "
                     + " | ".join(cells) + " |")
    lines += ["", "| effect | largest shift, any feature | feature | visible |", "|---|---|---|---|"]
    for j, column in enumerate(table.columns):
        if table.kinds[j] != "effect":
            continue
        i = int(np.argmax([abs(row[j]) for row in table.z]))
        size = abs(table.z[i][j])
        lines.append(f"| {column} | {size:.1f} | {table.rows[i]} | {'yes' if size >= VISIBLE else 'no'} |")
    return "\n".join(lines) + "\n"


def heatmap(table: Sensitivity, folder: Path, stem: str = "sensitivity") -> list[str]:
    """|shift| per feature and column as a heat map, the shifts written in, a line at
    :data:`VISIBLE`; PNG and SVG in ``folder``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from calibrax.report.figures import save_figure

    z = np.abs(np.array(table.z))
    fig, ax = plt.subplots(figsize=(1.2 + 0.62 * len(table.columns), 1.2 + 0.42 * len(table.rows)))
    image = ax.imshow(np.minimum(z, 4 * VISIBLE), cmap="viridis", vmin=0, vmax=4 * VISIBLE, aspect="auto")
    for i in range(z.shape[0]):
        for j in range(z.shape[1]):
            ax.text(j, i, f"{table.z[i][j]:+.1f}", ha="center", va="center", fontsize=7,
                    color="black" if z[i, j] > 2 * VISIBLE else "white", fontweight="bold" if z[i, j] >= VISIBLE else None)
    ax.set_xticks(range(len(table.columns)), table.columns, rotation=60, ha="right", fontsize=7)
    ax.set_yticks(range(len(table.rows)), [f"{n} ({g})" for n, g in zip(table.rows, table.groups)], fontsize=7)
    bar = fig.colorbar(image, ax=ax, fraction=0.03)
    bar.set_label(f"|shift| / (seed s.d. / √{table.replicates})")
    bar.ax.axhline(VISIBLE, color="red", lw=1.5)
    ax.set_title(f"What the test can see: shifts in noise units of a {table.replicates}-replicate mean "
                 f"(visible: ≥ {VISIBLE:g}, red line)", fontsize=9)
    return save_figure(fig, folder, stem)


def run_sensitivity(source: Path | None = None, *, design: Path | None = None, replicates: int = 3,
                    workers: int = 1, output: Path | None = None) -> Path:
    """The command's body: the point of ``source`` (a campaign store's answer, or a model file; the
    shipped model for None), its design (``design``'s rows, the shipped design for the shipped model,
    else run here, resumable, into ``output``), the table and heat map; returns the Markdown's path.
    Every input is checked before anything runs or is written."""
    from calibrax.core.registry import get_manager
    from calibrax.diagnosis.benchmark.design import run_design, shared_cases
    from calibrax.diagnosis.benchmark.emulated import DEFAULT_DESIGN, export_design, load_design
    from calibrax.diagnosis.benchmark.model import DEFAULT_MODEL, BenchmarkModel
    from calibrax.errors import ConfigError

    if replicates < 1:
        raise ConfigError("--replicates", f"must be ≥ 1, got {replicates}")
    if workers < 1:
        raise ConfigError("--workers", f"must be ≥ 1, got {workers}")
    if source is not None and not Path(source).is_file():
        raise ConfigError("SOURCE", f"{source}: no such campaign store or model file")
    is_store = source is not None and Path(source).suffix in (".h5", ".hdf5")
    model = BenchmarkModel.from_store(Path(source)) if is_store else BenchmarkModel.load(source)
    shipped = source is None or Path(source).resolve() == DEFAULT_MODEL.resolve()
    if design is None and shipped:
        design = DEFAULT_DESIGN
    out = Path(output) if output is not None else (
        Path(source).with_suffix(".sensitivity") if is_store else Path("runs") / f"sensitivity-{model.source.stem}")
    if design is not None:
        rows = load_design(design)["rows"]
        unlisted = shipped
    else:
        executor = get_manager().create("executor", "local", workers=workers)
        try:
            _, outcomes = run_design(model, out / "design", executor)
        finally:
            executor.shutdown()
        rows = export_design(model, outcomes, shared_cases(model)[0], "")["rows"]
        unlisted = False
    table = sensitivity(model, rows, replicates, unlisted=unlisted)
    return write(table, out, f"What the test can see: {model.simulator}, {model.spec.name} cell, "
                             f"{model.source.name}")


def write(table: Sensitivity, folder: Path, title: str) -> Path:
    """sensitivity.md, sensitivity.json and the heat map into ``folder``; returns the Markdown's path."""
    folder.mkdir(parents=True, exist_ok=True)
    heatmap(table, folder)
    (folder / "sensitivity.json").write_text(json.dumps(table.to_dict(), indent=1), encoding="utf-8")
    page = folder / "sensitivity.md"
    page.write_text(markdown(table, title) + "\n![sensitivity](sensitivity.png)\n", encoding="utf-8")
    return page


__all__ = ["Sensitivity", "sensitivity", "table_of", "run_sensitivity", "markdown", "heatmap", "write", "PARAMETER_STEP", "VISIBLE"]
