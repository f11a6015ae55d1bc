"""The report's figures (matplotlib, Agg): each function draws one figure and saves PNG and SVG.

Axes carry units; AIF in degrees, stresses in kPa, E in GPa where it is the parameter.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from calibrax.core.search.parameters import DISPLAY as UNITS  # noqa: E402  (symbol, scale, unit per parameter)
from calibrax.core.search.records import Status  # noqa: E402
from calibrax.core.search.surrogate import Kriging  # noqa: E402
from calibrax.report.data import CampaignData  # noqa: E402


def label(name: str) -> str:
    """Axis label of a parameter, with its unit."""
    sym, _, unit = UNITS.get(name, (name, 1.0, ""))
    return f"{sym} [{unit}]" if unit else sym


def value_text(name: str, value: float) -> str:
    """"E = 28 GPa", "μs = 0.3": a parameter's value in its display unit."""
    sym, factor, unit = UNITS.get(name, (name, 1.0, ""))
    return f"{sym} = {value * factor:.3g}" + (f" {unit}" if unit else "")


def scaled(name: str, value: float | np.ndarray) -> float | np.ndarray:
    """A parameter in its display unit (E in GPa)."""
    return np.asarray(value) * UNITS.get(name, (name, 1.0, ""))[1]


def save_figure(fig: plt.Figure, folder: Path, stem: str, layout: bool = True) -> list[str]:
    if layout:
        fig.tight_layout()
    names = []
    for ext in ("png", "svg"):
        fig.savefig(folder / f"{stem}.{ext}", dpi=130)
        names.append(f"{stem}.{ext}")
    plt.close(fig)
    return names


def _feature_model(data: CampaignData, attr: str) -> Kriging | None:
    pts = [p for p in data.points if math.isfinite(getattr(p, attr))]
    if len(pts) < 3:
        return None
    return Kriging.fit(np.stack([p.record.unit for p in pts]), np.array([getattr(p, attr) for p in pts]))


def cartography(data: CampaignData, folder: Path) -> list[str]:
    """The paper's figure 4: points in the (AIF, C) plane with regression error bars, iso-parameter
    lines predicted by Kriging models of C and AIF, the experiment, and the order of the search."""
    fig, ax = plt.subplots(figsize=(7.5, 5.8))
    c_model, a_model = _feature_model(data, "cohesion"), _feature_model(data, "aif")
    names = data.space.names
    centres: list[tuple[float, float]] = []  # (AIF °, C kPa) of what must be in view: lines, points, experiment
    labels: list[tuple[float, float, str, str, int]] = []
    if c_model is not None and a_model is not None and data.space.dim >= 2:
        base = data.best.record.unit.copy() if data.best is not None else np.full(data.space.dim, 0.5)
        sweep = np.linspace(0.0, 1.0, 60)
        for j, style in ((0, "-"), (1, "--")):
            other = 1 - j
            color = "tab:blue" if j == 0 else "tab:orange"
            for level in np.linspace(0.0, 1.0, 5):
                x = np.tile(base, (sweep.size, 1))
                x[:, j], x[:, other] = level, sweep
                c, _ = c_model.predict(x)
                a, _ = a_model.predict(x)
                ax.plot(a, c / 1e3, style, color=color, lw=0.9, alpha=0.6)
                centres.extend(zip(a, c / 1e3))
                end = -1 if j == 0 else 0  # iso-E labels at the high-μ end, iso-μ labels at the low-E end
                labels.append((float(a[end]), float(c[end] / 1e3),
                               value_text(names[j], data.space.parameters[j].from_unit(level)), color, j))
        ax.plot([], [], "-", color="tab:blue", label=f"iso-{UNITS.get(names[0], (names[0],))[0]} (Kriging)")
        ax.plot([], [], "--", color="tab:orange", label=f"iso-{UNITS.get(names[1], (names[1],))[0]} (Kriging)")
    ok = [p for p in data.points if math.isfinite(p.cohesion)]
    if ok:
        ax.errorbar([p.aif for p in ok], [p.cohesion / 1e3 for p in ok], xerr=[np.nan_to_num(p.aif_stderr) for p in ok],
                    yerr=[np.nan_to_num(p.cohesion_stderr) / 1e3 for p in ok], fmt="o", color="k", ms=4, capsize=2,
                    label="simulations (±1 regression s.e.)")
        for p in ok:
            ax.annotate(str(p.id), (p.aif, p.cohesion / 1e3), textcoords="offset points", xytext=(4, 4), fontsize=8)
    if data.best is not None and math.isfinite(data.best.cohesion):
        ax.plot(data.best.aif, data.best.cohesion / 1e3, "o", mfc="none", mec="tab:green", ms=14, mew=2,
                label=f"best: point {data.best.id}")
    if data.experiment is not None:
        locus = data.experiment.locus()
        s_c, s_a = data.experiment.spread()
        ax.errorbar([locus.aif_deg], [locus.cohesion / 1e3], xerr=[np.nan_to_num(s_a)], yerr=[np.nan_to_num(s_c) / 1e3],
                    fmt="s", color="tab:red", ms=8, capsize=4, label=f"experiment {data.experiment.name} (±1 replicate s.d.)")
        centres.append((locus.aif_deg, locus.cohesion / 1e3))
    centres.extend((p.aif, p.cohesion / 1e3) for p in ok)
    _frame(ax, centres)
    _place_labels(ax, labels)
    ax.set_xlabel("angle of internal friction AIF [°]")
    ax.set_ylabel("cohesion C [kPa]")
    ax.set_title("C–AIF cartography (numbers: order in which points were simulated)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return save_figure(fig, folder, "cartography")


def _frame(ax: plt.Axes, centres: list[tuple[float, float]], pad: float = 0.12) -> None:
    """Limits that hold every centre (points, experiment, iso-lines) with a margin, whatever the
    error bars: one point's wide bar no longer sets the range and squashes the rest into a band."""
    xy = np.array([c for c in centres if np.all(np.isfinite(c))], dtype=float).reshape(-1, 2)
    if len(xy) == 0:
        return
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = np.maximum(hi - lo, np.array([2.0, 0.5]))  # at least 2° and 0.5 kPa
    ax.set_xlim(lo[0] - pad * span[0], hi[0] + pad * span[0])
    ax.set_ylim(lo[1] - pad * span[1], hi[1] + pad * span[1])


def _place_labels(ax: plt.Axes, labels: list[tuple[float, float, str, str, int]], gap: float = 0.045) -> None:
    """Write the iso-line labels, skipping any that would land within ``gap`` (axes fraction) of one
    already written or outside the frame (converging lines otherwise pile their labels up)."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    placed: list[tuple[float, float]] = []
    for x, y, text, color, j in labels:
        fx, fy = (x - x0) / (x1 - x0), (y - y0) / (y1 - y0)
        if not (0.0 <= fx <= 0.92 and 0.02 <= fy <= 0.98):
            continue
        if any(abs(fx - px) < 2 * gap and abs(fy - py) < gap for px, py in placed):
            continue
        placed.append((fx, fy))
        ax.annotate(text, (x, y), fontsize=7, color=color, textcoords="offset points",
                    xytext=(3, 0 if j == 0 else -9))


def yield_loci(data: CampaignData, folder: Path, n_best: int = 3) -> list[str]:
    """τ_peak against σ for the experiment and the best simulations, with their fitted loci."""
    fig, ax = plt.subplots(figsize=(7, 5))
    sig_line = np.linspace(0.0, 10e3, 50)
    if data.experiment is not None:
        e = data.experiment
        ax.plot(e.normal_stress / 1e3, e.peak_shear_stress / 1e3, "s", color="tab:red", ms=5, label=f"experiment {e.name}")
        loc = e.locus()
        ax.plot(sig_line / 1e3, loc.shear_stress_at(sig_line) / 1e3, "-", color="tab:red",
                label=f"experiment fit: C = {loc.cohesion:.0f} Pa, AIF = {loc.aif_deg:.1f}°")
    best = sorted(data.done, key=lambda p: p.distance)[:n_best]
    for k, p in enumerate(best):
        color = plt.cm.viridis(k / max(1, n_best))
        sig = np.concatenate([r.target_normal_stress for r in p.results])
        tau = np.concatenate([r.peak_shear_stress for r in p.results])
        ax.plot(sig / 1e3, tau / 1e3, "o", color=color, ms=4)
        ax.plot(sig_line / 1e3, (p.cohesion + math.tan(math.radians(p.aif)) * sig_line) / 1e3, "--", color=color,
                label=f"point {p.id} (d = {p.distance:.2g}): C = {p.cohesion:.0f} Pa, AIF = {p.aif:.1f}°")
    ax.set_xlim(0, None)
    ax.set_xlabel("normal stress σ [kPa]")
    ax.set_ylabel("peak shear stress τ [kPa]")
    ax.set_title("Yield loci: experiment and best simulations")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, folder, "yield_loci")


def shear_curves(data: CampaignData, folder: Path) -> list[str]:
    """τ(rotation) of each shear step of the best point (first seed), with experimental curves."""
    best = data.best
    if best is None or not best.results:
        return []
    result = best.results[0]
    shear = [s for s in result.steps if s.kind == "shear"]
    fig, axes = plt.subplots(1, len(shear), figsize=(3.2 * len(shear), 3.6), sharey=True, squeeze=False)
    for k, (ax, step) in enumerate(zip(axes[0], shear)):
        ax.plot(step.rotation, step.shear_stress / 1e3, "-", color="k", lw=0.8, label="simulated τ")
        ax.plot(step.rotation, step.normal_stress / 1e3, "-", color="0.6", lw=0.6, label="simulated σ")
        ax.axhline(result.peak_shear_stress[k] / 1e3, color="tab:green", ls=":", label="peak")
        if data.experiment is not None:
            for (rep, sigma), (rot, tau) in data.experiment.curves.items():
                if abs(sigma - step.target_stress) < 1.0:
                    ax.plot(rot, tau / 1e3, "-", color="tab:red", lw=0.9, alpha=0.7,
                            label="experiment" if rep == min(r for r, _ in data.experiment.curves) else None)
        ax.set_title(f"σ = {step.target_stress / 1e3:.0f} kPa")
        ax.set_xlabel("head rotation [rad]")
        ax.grid(alpha=0.3)
        ax.text(0.97, 0.04, f"peak {result.peak_shear_stress[k]:.0f} Pa", transform=ax.transAxes, ha="right",
                fontsize=8, color="tab:green")
    axes[0][0].set_ylabel("stress [kPa]")
    axes[0][0].legend(fontsize=7)
    if data.experiment is None or not data.experiment.curves:
        fig.text(0.5, 0.01, "the experiment has no τ curves (only its peaks): a curves CSV adds them "
                 "(docs/reference/experiment-files.md)", ha="center", fontsize=8, color="0.3")
    fig.suptitle(f"Shear steps of the best point {best.id} (seed {result.provenance.seed}, {result.provenance.backend})")
    return save_figure(fig, folder, "shear_curves")


def surrogate_maps(data: CampaignData, folder: Path, grid: int = 70) -> tuple[list[str], str]:
    """Predicted distance and its standard deviation over the first two parameters (the others at
    the recommendation), with every evaluated point, the last batch's proposals, the answer's
    recommendation and the edge of its plausible region; returns the file names and the answer's
    statement (:mod:`calibrax.core.search.answer`) with what would narrow it."""
    from calibrax.core.search.answer import REGION_SIGMAS, answer_from_model
    from calibrax.core.search.points import fit_distance_model
    from calibrax.core.config import SURROGATE_DEFAULTS

    done = data.done
    if len(done) < 3 or data.space.dim < 1:
        return [], "too few finished points to fit a surrogate"
    options = {**SURROGATE_DEFAULTS, **(data.config.get("surrogate") or {})}
    seed = int(data.config.get("seed", 0))
    fidelities = data.config.get("fidelities")  # a multi-fidelity campaign's: the maps are the target's
    levels = {f["preset"]: float(f["level"]) for f in fidelities} if fidelities else None
    model = fit_distance_model([p.record for p in data.points], options, seed, levels=levels)
    limit, rate = data.noise_threshold
    answer = answer_from_model(model, data.space, limit, rate, len(done))
    rec_unit = data.space.to_unit(np.asarray([list(answer.params.values())]))[0]
    d2 = min(2, data.space.dim)
    base = rec_unit
    u = np.linspace(0, 1, grid)
    if d2 == 2:
        uu, vv = np.meshgrid(u, u)
        x = np.tile(base, (uu.size, 1))
        x[:, 0], x[:, 1] = uu.ravel(), vv.ravel()
    else:
        x = u.reshape(-1, 1)
    mean, std = model.predict(x)
    latent, latent_sd = model.latent(x)
    p0 = data.space.parameters[0]
    nat0 = scaled(p0.name, p0.from_unit(u))
    statement = _identifiability(data, answer)
    if not math.isfinite(limit):
        limit, rate = 1.0, math.nan
    inside = mean <= limit
    # the plausible region's edge on this slice: m − 2 s = t(T) in the model's units
    plausible = latent - REGION_SIGMAS * latent_sd - model.to_model_units(limit)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6))
    last_batch = max(p.record.batch for p in data.points)
    known = data.experiment.material if data.experiment is not None else {}
    rec = list(answer.params.values())
    if d2 == 2:
        p1 = data.space.parameters[1]
        nat1 = scaled(p1.name, p1.from_unit(u))
        truth = (known[p0.name], known[p1.name]) if p0.name in known and p1.name in known else None
        for ax, z, title in ((axes[0], mean, "predicted distance"), (axes[1], std, "prediction s.d.")):
            cs = ax.contourf(nat0, nat1, z.reshape(grid, grid), levels=20, cmap="viridis")
            fig.colorbar(cs, ax=ax)
            if np.any(inside):
                ax.contour(nat0, nat1, mean.reshape(grid, grid), levels=[limit], colors="w", linewidths=1.5)
            if plausible.max() > 0:  # hatch what the model rules out, edge dashed
                ax.contourf(nat0, nat1, plausible.reshape(grid, grid), levels=[0.0, float(plausible.max())],
                            colors="none", hatches=["//"])
                if plausible.min() < 0:
                    ax.contour(nat0, nat1, plausible.reshape(grid, grid), levels=[0.0], colors="tab:orange",
                               linewidths=1.5, linestyles="--")
            for p in data.points:
                xy = (scaled(p0.name, p.record.natural[0]), scaled(p1.name, p.record.natural[1]))
                if not math.isfinite(p.distance):
                    ax.plot(*xy, "x", color="r", ms=8)
                elif p.record.batch == last_batch and last_batch > 0:
                    ax.plot(*xy, "*", color="w", mec="k", ms=13)
                else:
                    ax.plot(*xy, "o", color="w", mec="k", ms=5)
            best = data.best.record.natural
            ax.plot(scaled(p0.name, best[0]), scaled(p1.name, best[1]), "D", mfc="none", mec="tab:red", mew=2,
                    ms=12, label=f"best observed point {data.best.id} (one draw of the noise)")
            ax.plot(scaled(p0.name, rec[0]), scaled(p1.name, rec[1]), "*", color="gold", mec="k", ms=16,
                    label="recommendation (minimum of the model's mean); hatched: ruled out, "
                          "orange dashes: edge of the plausible region")
            if truth is not None:
                ax.plot(scaled(p0.name, truth[0]), scaled(p1.name, truth[1]), "P", color="magenta", mec="k", ms=12,
                        label="truth (the pseudo-experiment's parameters)")
            for axis, p in ((ax.xaxis, p0), (ax.yaxis, p1)):
                if p.log:
                    (ax.set_xscale if axis is ax.xaxis else ax.set_yscale)("log")
                    axis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
                    axis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
                    axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.set_xlabel(label(p0.name))
            ax.set_ylabel(label(p1.name))
            line = f"white line: noise threshold d = {limit:.2g}" if np.any(inside) and not np.all(inside) else (
                f"all within the noise threshold d = {limit:.2g}" if np.all(inside) else
                f"none within the noise threshold d = {limit:.2g}")
            ax.set_title(f"{title} ({line}; ★ last batch; ✕ failed)", fontsize=9)
    else:
        ax = axes[0]
        ax.plot(nat0, mean, "k-", label="predicted distance")
        ax.fill_between(nat0, mean - 2 * std, mean + 2 * std, alpha=0.3, label="± 2 s.d.")
        ax.plot([scaled(p0.name, p.record.natural[0]) for p in done], [p.distance for p in done], "o",
                label="simulated points")
        ax.axhline(limit, color="tab:orange", ls="--", label=f"noise threshold d = {limit:.2g}")
        ruled_out = plausible > 0  # shade what the model rules out: m − 2 s above the threshold
        if ruled_out.any():
            ax.fill_between(nat0, 0, 1, where=ruled_out, transform=ax.get_xaxis_transform(), color="grey",
                            alpha=0.15, label="ruled out")
        ax.axvline(scaled(p0.name, rec[0]), color="gold", lw=2, label="recommendation")
        if p0.name in known:
            ax.axvline(scaled(p0.name, known[p0.name]), color="magenta", ls=":", lw=2,
                       label="truth (the pseudo-experiment's)")
        ax.set_ylabel("distance d")
        ax.set_title("predicted distance (grey: ruled out)", fontsize=9)
        axes[1].plot(nat0, std)
        axes[1].set_ylabel("prediction s.d.")
        axes[1].set_title("prediction s.d.", fontsize=9)
        for a in axes:
            a.set_xlabel(label(p0.name))
            if p0.log:
                a.set_xscale("log")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="lower center", ncol=2 if d2 == 2 else 4, fontsize=8,
               frameon=False)
    fig.suptitle("Kriging surrogate of the distance to the experiment")
    fig.tight_layout(rect=(0, 0.06, 1, 1))  # room for the legend under the panels
    return save_figure(fig, folder, "surrogate", layout=False), statement


def _cell_words(data: CampaignData) -> str:
    """" on the 'tiny' cell" when the campaign's cell names its preset, else "", and the sector when
    the cell is one (" (a 1/4 periodic sector of it)")."""
    cell = data.config.get("cell")
    preset = (cell.get("preset") or cell.get("name")) if isinstance(cell, dict) else None
    sector = cell.get("geometry", {}).get("sector", 1) if isinstance(cell, dict) else 1
    words = f" on the '{preset}' cell" if isinstance(preset, str) else ""
    return words + (f" (a 1/{sector} periodic sector of it)" if isinstance(sector, int) and sector > 1 else "")


def _identifiability(data: CampaignData, answer) -> str:
    """The answer's statement (:meth:`calibrax.core.search.answer.Answer.summary`) and what would narrow it:
    when the plausible region is most of the box, more replicates, more seeds or a less noisy
    preset (more points alone do not); when it is empty, whether the surrogate has too few points
    to say so yet."""
    text = answer.summary()
    n_done = len(data.done)
    enough = 10 * data.space.dim  # the usual EGO rule of thumb: about 10 evaluations per dimension
    if not math.isfinite(answer.threshold):
        return text + " This metric states no noise threshold, so the answer has no plausible region."
    if not answer.ranges:
        if n_done < enough:
            text += (f" With {n_done} finished points the surrogate is rough (EGO usually needs about {enough} for "
                     f"{data.space.dim} parameters): run more iterations before concluding that.")
        return text
    if answer.region_share >= 0.5:
        n_sims = sum(1 for p in data.done for s in getattr(p.record, "sims", []) if s.status == Status.DONE) or n_done
        one_sided = any(any(sides) for sides in answer.ruled_out.values())
        head = "bound the parameters from one side at most" if one_sided else "do not constrain the parameters"
        return text + (f" The data {head}: with {n_done} points ({n_sims} simulations)"
                       f"{_cell_words(data)} the experiment's replicate "
                       "spread and one simulation's seed noise leave most of the box as likely as the truth. More "
                       "replicates in the experiment, more seeds per point (seeds_per_point) or a less noisy "
                       "preset narrow it (docs/explanation/seed-noise.md); more points alone do not.")
    return text + (" A long, thin region is a valley of near-equivalent couples: the shear test alone cannot tell "
                   "them apart.")


def convergence(data: CampaignData, folder: Path) -> list[str]:
    """Best distance against the points simulated, and the engines' wall time per point; both
    panels number points as the store does (from 0), with whole-number ticks."""
    from matplotlib.ticker import MaxNLocator

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    order = sorted(data.points, key=lambda p: p.id)
    dist = np.array([p.distance for p in order])
    best = np.fmin.accumulate(np.where(np.isfinite(dist), dist, np.inf))
    n = np.array([p.id for p in order])
    ax1.plot(n, np.where(np.isfinite(best), best, np.nan), "-", color="k", label="best so far")
    ax1.plot(n[np.isfinite(dist)], dist[np.isfinite(dist)], "o", color="tab:blue", ms=4, label="each point")
    failed = ~np.isfinite(dist)
    if failed.any():
        top = np.nanmax(dist) if np.isfinite(dist).any() else 1.0
        ax1.plot(n[failed], np.full(failed.sum(), top), "x", color="r", ms=8, label="failed")
    ax1.set_yscale("log")
    ax1.set_xlabel("point (in the order simulated)")
    ax1.set_ylabel("distance to experiment")
    ax1.grid(alpha=0.3, which="both")
    ax1.legend(fontsize=8)
    colors = ["tab:red" if p.record.status == Status.FAILED else "tab:blue" for p in order]
    ax2.bar(n, [p.wall_time for p in order], color=colors)
    ax2.set_xlabel("point (in the order simulated)")
    ax2.set_ylabel("engine wall time, all seeds [s]")
    if "tab:red" in colors:
        ax2.set_title("red: failed", fontsize=9)
    for ax in (ax1, ax2):
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    return save_figure(fig, folder, "convergence")
