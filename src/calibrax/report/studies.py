"""Tables (Markdown) and figures (PNG/SVG) of the cross-check and convergence studies."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Ellipse  # noqa: E402

from calibrax.core.convergence import Verdict  # noqa: E402
from calibrax.core.crosscheck import Agreement  # noqa: E402
from calibrax.core.study import CaseOutcome  # noqa: E402
from calibrax.report.figures import _save  # noqa: E402

MARKERS = "osD^v<>p*h"


def _fmt(v: float, digits: str = ".0f") -> str:
    return format(v, digits) if isinstance(v, float) and math.isfinite(v) else "–"


def outcome_row(o: CaseOutcome) -> str:
    s = o.summary()
    peaks = " / ".join(_fmt(s[k] / 1e3, ".2f") for k in s if k.startswith("peak_") and not k.endswith("_sd"))
    return (f"| {o.case.label} | {o.case.backend} | {int(s['seeds_ok'])}/{len(o.case.seeds)} | {peaks} | "
            f"{_fmt(s.get('bulk_density', math.nan))} | {_fmt(s.get('cohesion', math.nan))} ± "
            f"{_fmt(s.get('cohesion_stderr', math.nan))} (sd {_fmt(s.get('cohesion_seed_sd', math.nan))}) | "
            f"{_fmt(s.get('aif', math.nan), '.1f')} ± {_fmt(s.get('aif_stderr', math.nan), '.1f')} "
            f"(sd {_fmt(s.get('aif_seed_sd', math.nan), '.1f')}) | {_fmt(s.get('wall_time', math.nan), '.0f')} |")


HEAD = ("| case | backend | seeds ok | τ_peak per step [kPa] | ρ_bulk [kg/m³] | C ± s.e. (seed s.d.) [Pa] | "
        "AIF ± s.e. (seed s.d.) [°] | wall [s] |\n|---|---|---|---|---|---|---|---|")


def crosscheck_markdown(outcomes: list[CaseOutcome], agree: list[Agreement], micro_rows: list) -> str:
    lines = ["# Cross-check", "", "## Shear test", "", HEAD, *[outcome_row(o) for o in outcomes], "",
             "## Agreement (|Δ| ≤ 2·√(u_a² + u_b²), u = max(regression s.e., seed s.d./√n))", "",
             "| case | quantity | backends | Δ | limit | agree |", "|---|---|---|---|---|---|"]
    for a in agree:
        lines.append(f"| {a.point} | {a.quantity} | {a.backend_a} − {a.backend_b} | {a.difference:.3g} | "
                     f"{a.limit:.3g} | {'yes' if a.agree else '**no**'} |")
    lines += ["", "## Micro-level checks (agree: within 2 % of their mean)", "",
              "| case | quantity | values | agree |", "|---|---|---|---|"]
    for case, key, values, ok in micro_rows:
        shown = ", ".join(f"{b}: {v:.5g}" for b, v in values.items())
        lines.append(f"| {case} | {key} | {shown} | {'yes' if ok else '**no**'} |")
    for o in outcomes:
        for reason in o.failures:
            lines.append(f"\nFAILED: {o.case.label} on {o.case.backend}: {reason}")
    return "\n".join(lines) + "\n"


def crosscheck_figure(outcomes: list[CaseOutcome], folder: Path) -> list[str]:
    """C–AIF plane, one colour per backend and one marker per point, 2u error ellipses; and the
    mean peaks per step."""
    backends = sorted({o.case.backend for o in outcomes})
    points = list(dict.fromkeys(o.case.label for o in outcomes))
    colors = {b: plt.cm.tab10(i) for i, b in enumerate(backends)}
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 5))
    for o in outcomes:
        s = o.summary()
        if "cohesion" not in s:
            continue
        c, m = colors[o.case.backend], MARKERS[points.index(o.case.label) % len(MARKERS)]
        ax.plot(s["aif"], s["cohesion"] / 1e3, m, color=c, ms=8)
        ax.add_patch(Ellipse((s["aif"], s["cohesion"] / 1e3), 4 * s["aif_u"], 4 * s["cohesion_u"] / 1e3,
                             fill=False, color=c, lw=1.2))
        for r in o.good:
            ax.plot(r.yield_locus().aif_deg, r.yield_locus().cohesion / 1e3, ".", color=c, ms=4, alpha=0.6)
        sig = o.good[0].target_normal_stress
        mean = [s[f"peak_{x:.0f}"] / 1e3 for x in sig]
        sd = [s[f"peak_{x:.0f}_sd"] / 1e3 if math.isfinite(s[f"peak_{x:.0f}_sd"]) else 0.0 for x in sig]
        ax2.errorbar(sig / 1e3, mean, yerr=sd, fmt=m + "-", color=c, capsize=3, ms=6)
    for b in backends:
        ax.plot([], [], "s", color=colors[b], label=b)
    for j, p in enumerate(points):
        ax.plot([], [], MARKERS[j % len(MARKERS)], color="k", label=p)
    ax.set_xlabel("AIF [°]")
    ax.set_ylabel("C [kPa]")
    ax.set_title("Pooled locus per backend (ellipse: ±2u); dots: single seeds", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax2.set_xlabel("normal stress σ [kPa]")
    ax2.set_ylabel("peak shear stress τ [kPa] (mean ± seed s.d.)")
    ax2.grid(alpha=0.3)
    return _save(fig, folder, "crosscheck")


def converge_markdown(outcomes: list[CaseOutcome], results: list[Verdict]) -> str:
    lines = ["# Convergence study", ""]
    for v in results:
        lines += [f"**{v.sentence()}.**", ""]
    lines += [HEAD.replace("| case |", "| setting |").rstrip() + "", *[outcome_row(o) for o in outcomes]]
    lines += ["", "| setting | particles | within the finest's uncertainty |", "|---|---|---|"]
    for v in results:
        for value, s, within in v.rows:
            lines.append(f"| {v.knob}={value:g} | {_fmt(s.get('particles', math.nan))} | {'yes' if within else 'no'} |")
    return "\n".join(lines) + "\n"


def converge_figure(outcomes: list[CaseOutcome], results: list[Verdict], folder: Path) -> list[str]:
    """C and AIF (±2u) against each knob, the finest's band shaded."""
    fig, axes = plt.subplots(len(results), 2, figsize=(11, 3.6 * len(results)), squeeze=False)
    for row, v in zip(axes, results):
        xs = [value for value, _, _ in v.rows]
        for ax, q, scale, unit in ((row[0], "cohesion", 1e-3, "C [kPa]"), (row[1], "aif", 1.0, "AIF [°]")):
            ys = [s.get(q, math.nan) * scale for _, s, _ in v.rows]
            es = [2 * s.get(f"{q}_u", math.nan) * scale for _, s, _ in v.rows]
            ax.errorbar(xs, ys, yerr=es, fmt="o-", capsize=3)
            fine = [s for value, s, _ in v.rows if value == v.finest][0]
            if q in fine:
                ax.axhspan((fine[q] - 2 * fine[f"{q}_u"]) * scale, (fine[q] + 2 * fine[f"{q}_u"]) * scale,
                           color="tab:green", alpha=0.15, label="finest ± 2u")
            ax.set_xlabel(v.knob)
            ax.set_ylabel(unit)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        row[0].set_title(v.sentence(), fontsize=8, loc="left")
    return _save(fig, folder, "converge")
