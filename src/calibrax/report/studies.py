"""Tables (Markdown) and figures (PNG/SVG) of the cross-check and convergence studies."""

from __future__ import annotations

import math
import re
import textwrap
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Ellipse  # noqa: E402

from calibrax.core.studies.convergence import DENSITY_TOLERANCE, Verdict, inertial_numbers  # noqa: E402
from calibrax.core.sheartest.verification import MICRO_CASES
from calibrax.core.studies.crosscheck import Agreement, MicroRow, micro_errors
from calibrax.core.sheartest import BASE_SLIP_FRACTION, BASE_SPIN_SLIP_FRACTION  # noqa: E402
from calibrax.core.studies.study import CaseOutcome  # noqa: E402
from calibrax.report.figures import save_figure  # noqa: E402

MARKERS = "osD^v<>p*h"
#: micro-level values that are the analytic theory, not a measurement (the same on every backend)
THEORY = {"hertz_contact_time", "expected", "sliding_time"}


def _fmt(v: float, digits: str = ".0f") -> str:
    return format(v, digits) if isinstance(v, float) and math.isfinite(v) else "–"


def _peak_keys(s: dict[str, float]) -> list[str]:
    return [k for k in s if re.fullmatch(r"peak_\d+", k)]


def outcome_row(o: CaseOutcome, agree: str | None = None) -> str:
    """One table row: peaks per step (± seed s.d.), bulk density, C and AIF (± regression s.e.,
    seed s.d.), wall time, and (cross-check) the agreement with the other backends."""
    s = o.summary()
    peaks = []
    for k in _peak_keys(s):
        sd = s.get(f"{k}_sd", math.nan)
        peaks.append(_fmt(s[k] / 1e3, ".2f") + (f" ± {sd / 1e3:.2f}" if math.isfinite(sd) else ""))
    k = o.case.spec.geometry.sector
    cells = [o.case.label, o.case.backend + (f" (1/{k} sector)" if k > 1 else ""), f"{int(s['seeds_ok'])}/{len(o.case.seeds)}", " / ".join(peaks) or "–",
             _fmt(s.get("bulk_density", math.nan)) + (f" ± {s['bulk_density_sd']:.0f}"
                                                      if math.isfinite(s.get("bulk_density_sd", math.nan)) else ""),
             f"{_fmt(s.get('cohesion', math.nan))} ± {_fmt(s.get('cohesion_stderr', math.nan))} "
             f"(sd {_fmt(s.get('cohesion_seed_sd', math.nan))})",
             f"{_fmt(s.get('aif', math.nan), '.1f')} ± {_fmt(s.get('aif_stderr', math.nan), '.1f')} "
             f"(sd {_fmt(s.get('aif_seed_sd', math.nan), '.1f')})",
             _fmt(s.get("wall_time", math.nan), ".0f")]
    if agree is not None:
        cells.append(agree)
    return "| " + " | ".join(cells) + " |"


def _sigma_header(outcomes: list[CaseOutcome]) -> str:
    for o in outcomes:
        if o.good:
            return "/".join(f"{x / 1e3:g}" for x in o.good[0].target_normal_stress)
    return "…"


def table_head(outcomes: list[CaseOutcome], first: str = "case", agreement: bool = False) -> str:
    cols = [first, "backend", "seeds ok", f"τ_peak at σ = {_sigma_header(outcomes)} kPa [kPa] (± seed s.d.)",
            "ρ_bulk after preshear [kg/m³] (± seed s.d.)", "C ± regr. s.e. (seed s.d.) [Pa]",
            "AIF ± regr. s.e. (seed s.d.) [°]",
            "wall [s]"]
    if agreement:
        cols.append("agrees with (C, AIF; ρ_bulk with ≥ 2 seeds)")
    return "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols)


def _agreement_cell(o: CaseOutcome, agree: list[Agreement]) -> str:
    """Per other backend at the same point: "liggghts ✓✓" (C ✓, AIF ✓) or ✗ where it disagrees."""
    parts: dict[str, dict[str, bool]] = {}
    for a in agree:
        if a.point != o.case.label or o.case.backend not in (a.backend_a, a.backend_b):
            continue
        other = a.backend_b if a.backend_a == o.case.backend else a.backend_a
        parts.setdefault(other, {})[a.quantity] = a.agree
    if not parts:
        return "–"
    def word(q: dict[str, bool], key: str, name: str) -> str:
        return "" if key not in q else f"{name} {'yes' if q[key] else '**no**'}"

    return "; ".join(f"{b}: " + ", ".join(filter(None, (word(q, "cohesion", "C"), word(q, "aif", "AIF"),
                                                         word(q, "bulk_density", "ρ"),
                                                         word(q, "conditioned_bulk_density", "CBD"))))
                     for b, q in parts.items())


def servo_table(outcomes: list[CaseOutcome]) -> list[str]:
    """Lines of the "σ while shearing" section: how steadily each backend's servo held σ in the
    shear windows, σ at the τ peak, and the steady τ/σ (see ``study.shear_window_diagnostics``)."""
    lines = ["## σ while shearing", "",
             "The peak is the largest τ of a shear window and τ follows σ: a servo that lets σ swing reads a "
             "higher peak at the same target. Where backends' peaks differ, compare these before the contact "
             "laws. Steady: the second half of each window; mean over shear steps and seeds (± seed s.d.). "
             "Base load: steady τ over the most a flat base can hold the bed against (μ_base [σ R_v/R_h + "
             "ρ g H (R_v/R_h)³], uniform pressure, frictionless lateral wall; – with ribs or wall friction): "
             f"at ≥ {BASE_SLIP_FRACTION:.0%} the bed slides on the base and τ measures the base's friction, and "
             "anything else that resists the turning bed (a lateral wall that is not smooth) adds to τ. "
             "Base slip: the bottom layer's spin over the head's rate, measured on every base "
             f"(≥ {BASE_SPIN_SLIP_FRACTION:.0%}: the bed slid on it). Peak τ/σ: τ_peak over the σ measured at "
             "the peak, and preshear τ/σ, the robust features (mean over steps). Preshear: how far the "
             "preshears turned before τ/σ was steady (mean) and the largest drift of τ/σ between their last two "
             "windows (above the procedure's tolerance: a preshear stopped at its cap unsteady).", "",
             "| case | backend | s.d. of σ / target | σ at the τ peak / target − 1 | steady τ/σ | peak τ/σ | "
             "preshear τ/σ | base load | base slip | preshear rotation | preshear drift |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for o in outcomes:
        s = o.summary()

        def cell(key: str, scale: float, digits: str, unit: str) -> str:
            v, sd = s.get(key, math.nan), s.get(f"{key}_sd", math.nan)
            if not math.isfinite(v):
                return "–"
            return _fmt(v * scale, digits) + (f" ± {sd * scale:{digits.lstrip('+')}}" if math.isfinite(sd) else "") + unit

        lines.append(f"| {o.case.label} | {o.case.backend} | {cell('sigma_sd', 100, '.1f', ' %')} | "
                     f"{cell('sigma_offset_at_peak', 100, '+.1f', ' %')} | {cell('steady_friction', 1, '.3f', '')} | "
                     f"{cell('peak_ratio', 1, '.3f', '')} | {cell('preshear_ratio', 1, '.3f', '')} | "
                     f"{cell('base_load', 100, '.0f', ' %')} | {cell('base_slip', 100, '.0f', ' %')} | "
                     f"{cell('preshear_rotation', 1, '.2f', ' rad')} | {cell('preshear_drift', 100, '.1f', ' %')} |")
    return lines + [""]


def crosscheck_markdown(outcomes: list[CaseOutcome], agree: list[Agreement], micro_rows: list[MicroRow],
                        micro_checks: dict | None = None, known: dict | None = None,
                        material: dict[str, float] | None = None) -> str:
    """The cross-check's Markdown page: the shear test per point and backend (with agreement),
    the pairwise agreement table, and the micro-level checks side by side."""
    lines = ["# Cross-check", "", "## Shear test per point and backend", "",
             "C and AIF: one straight-line fit through the peaks of every seed (regression s.e.) and the s.d. of the "
             "seeds' own fits; agreement: |Δ| ≤ 2·√(u_a² + u_b²), u = max(regression s.e., seed s.d./√n) (ρ_bulk: "
             "u = seed s.d./√n).", "",
             table_head(outcomes, agreement=True), *[outcome_row(o, _agreement_cell(o, agree)) for o in outcomes], "",
             *servo_table(outcomes),
             "## Agreement between backends", "",
             "| case | quantity | backends | Δ | limit 2·√(u_a² + u_b²) | agree |", "|---|---|---|---|---|---|"]
    names = {"cohesion": ("C", ".0f", " Pa"), "aif": ("AIF", ".1f", "°"), "bulk_density": ("ρ_bulk", ".0f", " kg/m³"),
             "conditioned_bulk_density": ("CBD", ".0f", " kg/m³")}
    for a in agree:
        name, digits, unit = names[a.quantity]
        lines.append(f"| {a.point} | {name} | {a.backend_a} − {a.backend_b} | "
                     f"{_fmt(a.difference, digits)}{unit} | {_fmt(a.limit, digits)}{unit} | "
                     f"{'yes' if a.agree else '**no**'} |")
    if not agree:
        lines.append("| – | – | – | – | – | (needs ≥ 2 backends with a fitted locus) |")
    backends = list(dict.fromkeys(b for r in micro_rows for b in r.values))
    lines += ["", "## Micro-level checks", ""]
    if material:
        lines += ["At the campaign's material: " + ", ".join(f"{k} = {v:g}" for k, v in material.items())
                  + " (SI units). Agree: all values within 2 % of their mean (energy change: 2 % of the impact's "
                    "kinetic energy).", ""]
    notes: dict[str, int] = {}
    if not micro_rows:
        lines.append("Not run (`--no-micro`)." if material is None
                     else "No micro-level quantity was measured by two or more backends.")
    else:
        lines += ["| case | quantity | " + " | ".join(backends) + " | spread / mean | agree |",
                  "|---|---|" + "---|" * len(backends) + "---|---|"]
    for r in micro_rows:
        mean = sum(r.values.values()) / len(r.values)
        spread = (max(r.values.values()) - min(r.values.values())) / abs(mean) if mean else math.nan
        if r.agree:
            verdict = "yes"
        elif r.known:
            refs = []
            for b in r.known:
                why = (known or {}).get(b, {}).get((MICRO_CASES.get(r.case, (r.case,))[0], r.quantity), "")
                notes.setdefault(f"{b}: {why}", len(notes) + 1)
                refs.append(f"[{notes[f'{b}: {why}']}]")
            verdict = f"**no**: known difference of {', '.join(r.known)} {''.join(refs)}" + (
                "" if r.others_agree else "; the others disagree too")
        else:
            verdict = "**no**"
        shown = " | ".join(f"{r.values[b]:.5g}" if b in r.values else "–" for b in backends)
        quantity = f"{r.quantity} (theory)" if r.quantity in THEORY else r.quantity
        lines.append(f"| {r.case} | {quantity} | {shown} | {_fmt(spread * 100, '.2f')} % | {verdict} |")
    if notes:
        lines += ["", "Known differences of the contact laws (by construction, not bugs):", ""]
        lines += [f"{n}. {text}" for text, n in notes.items()]
    for case, backend, error in micro_errors(micro_checks or {}):
        lines.append(f"\nMICRO CHECK FAILED: {case} on {backend}: {error}")
    for o in outcomes:
        for reason in o.failures:
            lines.append(f"\nFAILED: {o.case.label} on {o.case.backend}: {reason}")
    return "\n".join(lines) + "\n"


def crosscheck_figure(outcomes: list[CaseOutcome], folder: Path) -> list[str]:
    """Left: the C–AIF plane, one marker (shape and colour) per backend, the pooled locus of each
    point with its ±2u error ellipse, the seeds' own loci as small dots; points labelled P0, P1….
    Right: the mean peak τ per step (± seed s.d.) against σ."""
    backends = sorted({o.case.backend for o in outcomes})  # the same style for a backend in every run
    points = list(dict.fromkeys(o.case.label for o in outcomes))
    colors = {b: plt.cm.tab10(i) for i, b in enumerate(backends)}
    markers = {b: MARKERS[i % len(MARKERS)] for i, b in enumerate(backends)}
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 5.2))
    drawn = set()
    for o in outcomes:
        s = o.summary()
        if "cohesion" not in s:
            continue
        b = o.case.backend
        c, m = colors[b], markers[b]
        x, y = s["aif"], s["cohesion"] / 1e3
        ax.plot(x, y, m, color=c, ms=9, mec="k", mew=0.6, zorder=3, label=None if b in drawn else b)
        w, h = 4 * s["aif_u"], 4 * s["cohesion_u"] / 1e3
        if math.isfinite(w) and math.isfinite(h):
            ax.add_patch(Ellipse((x, y), w, h, fill=True, fc=(*c[:3], 0.12), ec=c, lw=1.4, zorder=2))
        for loc in o.seed_loci():
            ax.plot(loc.aif_deg, loc.cohesion / 1e3, ".", color=c, ms=4, alpha=0.7, zorder=2)
        if len(points) > 1:
            ax.annotate(o.case.label.split(":")[0], (x, y), textcoords="offset points", xytext=(6, 6), fontsize=8)
        sig = o.good[0].target_normal_stress
        mean = [s[f"peak_{v:.0f}"] / 1e3 for v in sig]
        sd = [s[f"peak_{v:.0f}_sd"] / 1e3 if math.isfinite(s[f"peak_{v:.0f}_sd"]) else 0.0 for v in sig]
        label = b if len(points) == 1 else f"{b}, {o.case.label.split(':')[0]}"
        ax2.errorbar(sig / 1e3, mean, yerr=sd, fmt=m, color=c, capsize=3, ms=7, mec="k", mew=0.6, label=label)
        grid = np.linspace(0.0, float(np.max(sig)) * 1.05, 50)
        line = (s["cohesion"] + grid * math.tan(math.radians(s["aif"]))) / 1e3
        ax2.plot(grid / 1e3, line, "--", color=c, lw=1.2)
        if len(points) > 1:
            ax2.annotate(o.case.label.split(":")[0], (grid[-1] / 1e3, line[-1]), textcoords="offset points",
                         xytext=(3, 0), fontsize=8, va="center", color=c)
        drawn.add(b)
    ax.autoscale_view()
    ax.set_xlabel("AIF [°]")
    ax.set_ylabel("C [kPa]")
    ax.set_title("Pooled yield locus per backend: ellipse ±2u (u = max(regr. s.e., seed s.d./√n)); "
                 "dots: single seeds", fontsize=9)
    ax.grid(alpha=0.3)
    if drawn:
        ax.legend(fontsize=8, title="backend", title_fontsize=8)
    ax2.set_xlabel("normal stress σ [kPa]")
    ax2.set_ylabel("peak shear stress τ [kPa] (mean ± seed s.d.)")
    ax2.set_title("Peak τ of each shear step (mean ± seed s.d.); dashed: fitted yield locus", fontsize=9)
    ax2.grid(alpha=0.3)
    if drawn:
        ax2.legend(fontsize=8)
    if len(points) > 1:
        fig.text(0.01, 0.01, "; ".join(points), fontsize=7, ha="left", va="bottom")
    return save_figure(fig, folder, "crosscheck")


def converge_markdown(outcomes: list[CaseOutcome], results: list[Verdict]) -> str:
    """The convergence study's Markdown page: the verdict per knob, the table per setting, and
    which settings lie within the finest's uncertainty."""
    lines = ["# Convergence study", ""]
    for v in results:
        lines += [f"**{v.sentence()}.**", ""]
    lines += ["Within: |C − C_finest| ≤ 2·√(u² + u_finest²) and the same for AIF, u = max(regression s.e., "
              "seed s.d./√n); and |ρ − ρ_finest| ≤ max(2·√(u² + u_finest²), "
              f"{DENSITY_TOLERANCE:.0%} of ρ_finest) for the bulk density after preshear, u = seed s.d./√n.", "", table_head(outcomes, first="setting"), *[outcome_row(o) for o in outcomes]]
    lines += ["", "| setting | particles | cell diameter / particle diameter | time step [s] | "
                  "inertial number I of the shear steps | within the finest's uncertainty |",
              "|---|---|---|---|---|---|"]
    by_coords = {tuple(o.case.coords.items()): o for o in outcomes}
    for v in results:
        for value, s, within in v.rows:
            o = by_coords.get(((v.knob, value),))
            spec = o.case.spec if o is not None else None
            inertial = ", ".join(f"{i:.2g}" for i in inertial_numbers(spec)) if spec is not None else "–"
            lines.append(f"| {v.knob}={value:g} | {_fmt(s.get('particles', math.nan))} | "
                         f"{_fmt(spec.particles_per_diameter if spec else math.nan, '.1f')} | "
                         f"{_fmt(spec.time_step if spec else math.nan, '.3g')} | {inertial} | "
                         f"{'yes' if within else 'no'}{' (finest)' if value == v.finest else ''} |")
    lines += ["", *servo_table(outcomes)]
    for o in outcomes:
        for reason in o.failures:
            lines.append(f"\nFAILED: {o.case.label}: {reason}")
    return "\n".join(lines) + "\n"


def converge_figure(outcomes: list[CaseOutcome], results: list[Verdict], folder: Path) -> list[str]:
    """One row per knob: C and AIF (±2u) against the knob with the finest setting's ±2u band
    shaded; and the yield loci (peaks and fitted lines) of every setting."""
    fig, axes = plt.subplots(len(results), 3, figsize=(15, 4.4 * len(results)), squeeze=False)
    by_coords = {tuple(o.case.coords.items()): o for o in outcomes}
    for row, v in zip(axes, results):
        xs = [value for value, _, _ in v.rows]
        fine = [s for value, s, _ in v.rows if value == v.finest][0]
        for ax, q, scale, unit in ((row[0], "cohesion", 1e-3, "C [kPa]"), (row[1], "aif", 1.0, "AIF [°]")):
            ys = [s.get(q, math.nan) * scale for _, s, _ in v.rows]
            es = [2 * s.get(f"{q}_u", math.nan) * scale for _, s, _ in v.rows]
            ax.errorbar(xs, ys, yerr=es, fmt="o-", capsize=3, color="tab:blue", label="±2u")
            ok = [(value, s.get(q, math.nan) * scale) for value, s, within in v.rows if within and value != v.finest]
            if ok:
                ax.plot(*zip(*ok), "o", ms=12, mfc="none", mec="tab:green", mew=1.6,
                        label="C, AIF and ρ within the finest's uncertainty")
            if q in fine and math.isfinite(fine[f"{q}_u"]):
                ax.axhspan((fine[q] - 2 * fine[f"{q}_u"]) * scale, (fine[q] + 2 * fine[f"{q}_u"]) * scale,
                           color="tab:green", alpha=0.15, label="finest ± 2u")
            ax.set_title(f"{unit.split()[0]} against the {v.knob.replace('_', ' ')}", fontsize=9)
            ax.set_xticks(xs)
            ax.set_xlabel(v.knob.replace("_", " "))
            ax.set_ylabel(unit)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        ax = row[2]
        colors = plt.cm.viridis(np.linspace(0.0, 0.85, max(len(v.rows), 1)))
        for (value, s, _), c in zip(v.rows, colors):
            o = by_coords.get(((v.knob, value),))
            if o is None or not o.good or "cohesion" not in s:
                continue
            sig = o.good[0].target_normal_stress
            ax.plot(np.concatenate([r.target_normal_stress for r in o.good]) / 1e3,
                    np.concatenate([r.peak_shear_stress for r in o.good]) / 1e3, "o", color=c, ms=5,
                    label=f"{value:g}")
            grid = np.linspace(0.0, float(np.max(sig)) * 1.05, 50)
            ax.plot(grid / 1e3, (s["cohesion"] + grid * math.tan(math.radians(s["aif"]))) / 1e3, "-", color=c, lw=1.2)
        ax.set_xlabel("normal stress σ [kPa]")
        ax.set_ylabel("peak shear stress τ [kPa]")
        ax.set_title("Yield loci: peaks of every seed and fitted line", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, title=v.knob.replace("_", " "), title_fontsize=8)
        note = row[0].annotate(textwrap.fill(v.sentence() + ".", 150), (0.0, 1.0), xycoords="axes fraction",
                               xytext=(0, 26), textcoords="offset points", fontsize=10, fontweight="bold",
                               va="bottom")
        note.set_in_layout(False)
    fig.tight_layout(h_pad=6.0)
    fig.subplots_adjust(top=1.0 - 0.75 / (4.4 * len(results)))
    return save_figure(fig, folder, "converge", layout=False)
