"""A diagnosis as Markdown and figures: residuals per feature before and after, τ curves before and
after against the experiment, the candidates' scores."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from calibrax.diagnosis.gap import FeatureGap
from calibrax.diagnosis.run import Calibrated, Diagnosis, level_words
from calibrax.diagnosis.scoring import IMPLAUSIBLE_Z, MIN_BAYES_FACTOR, NO_EFFECT, NONE_OF_THEM

CAPTIONS = {
    "diagnosis_residuals": "Each feature's standardised residual (simulation − experiment over the combined "
                           "standard error) at the calibrated point (before) and at the recalibration with the top "
                           "effect (after); the shaded band is |z| ≤ 3; held-out features are marked *.",
    "diagnosis_curves": "τ curves of each shear step: the experiment's replicates, the calibrated model's seeds "
                        "(before) and the recalibrated model's seeds (after).",
    "diagnosis_scores": "Each model's Bayes factor against no effect (log scale; the verdict in green), its "
                        "probability (equal prior odds) and the largest |z| it leaves at its best fit.",
}


def _fmt(v: float) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{v:.4g}"


def headline(d: Diagnosis) -> str:
    """The verdict in one sentence."""
    reason = d.reason
    if d.verdict == NONE_OF_THEM:
        return "None of the candidates explains the gap: " + reason.removeprefix(NONE_OF_THEM + ": ")
    return reason[:1].upper() + reason[1:]


def shrinkage_text(d: Diagnosis) -> str:
    """The held-out gap before and after, and what it means."""
    before, after = d.gap_before, d.gap_after
    text = f"Held-out gap (RMS of z; about 1 is the noise): {_fmt(before)} before, {_fmt(after)} after"
    if not d.after:
        text += " (nothing was recalibrated, so the gap stays what it was)"
    if not any(g.implausible for g in d.held_out("before")):
        return text + (": the held-out features were within the noise before (no |z| > 3), so there was no "
                       "held-out gap to shrink; the after column shows the recalibration did not open one.")
    return text + f": it shrinks by {_fmt(100 * d.shrinkage)} %."


def _cost_by_fidelity(d: Diagnosis) -> str:
    """" By fidelity: tiny 48 simulations, 52 CPU-min; converged 4, 168 CPU-min." ("" at one)."""
    rows = d.simulations.get("by_fidelity") or {}
    if not rows:
        return ""
    return " By fidelity: " + "; ".join(f"{name} {row['simulations']} simulations, "
                                        f"{row.get('cpu_seconds', row['engine_seconds']) / 60:.0f} CPU-min"
                                        for name, row in rows.items()) + "."


def markdown(d: Diagnosis) -> str:
    """The diagnosis's summary."""
    lines = [f"# Diagnosis of the sim-to-real gap ({d.backend})", "", f"**Verdict.** {headline(d)}", "",
             f"Candidates: {', '.join(d.effects)}" + (f"; skipped: " + "; ".join(f"{k} ({v})" for k, v in d.skipped.items())
                                                       if d.skipped else "") + ".",
             f"Design box: " + ", ".join(f"{k} {lo:.4g} to {hi:.4g}" for k, (lo, hi) in d.box.items())
             + f"; calibrated point " + ", ".join(f"{k} = {v:.4g}" for k, v in d.centre.items()) + ".",
             f"Cost: {d.simulations['total']} simulations ({d.simulations['design']} in the design, "
             f"{d.simulations['design_failed']} of them failed; {d.simulations['confirm']} to confirm), "
             f"{d.simulations.get('engine_seconds', 0) / 60:.0f} min of engine time in all"
             + (f" ({d.simulations['cpu_seconds'] / 60:.0f} CPU-min)" if "cpu_seconds" in d.simulations else "") + ", "
             f"{d.wall_time / 60:.1f} min of wall time in this run." + _cost_by_fidelity(d), "",
             "## 1. Where the gap lies (calibrated point, replicate seeds)", "", *_metric_line(d),
             *_gap_table(d.before, d.judge_on), "",
             "## 2. Which effect", "",
             "| model | probability | log evidence | effect at best fit | 95 % interval | max |z| at best fit | prior |",
             "|---|---|---|---|---|---|---|"]
    for m in d.ranking.models:
        best = ", ".join(f"{k} = {v:.3g}" for k, v in m.best_effect.items()) or "–"
        interval = ", ".join(f"{lo:.3g} to {hi:.3g}" for lo, hi in m.effect_interval.values()) or "–"
        lines.append(f"| {m.label} | {m.probability:.3f} | {m.log_evidence:.2f} | {best} | {interval} | "
                     f"{m.max_abs_z:.2f} | {'; '.join(m.prior_text) or '–'} |")
    lines += _emulator_findings(d)
    lines += ["", "## 3. Does it survive its confirmation", "", *_confirmations(d)]
    if not d.judge_on:
        lines.append(f"No recalibration: every feature the experiment has ({', '.join(d.features)}) is in the groups "
                     f"it would be fitted to ({', '.join(d.fit_on)}), so none is left to judge it on. τ curves or a "
                     "bulk density in the experiment, or other --fit-on groups, give it some.")
    elif not d.recalibrated:
        lines.append("Nothing adopted: no candidate was confirmed, so the gap stays what it was." if d.final.confirmations
                     else "Nothing to add: no candidate was worth confirming, so no recalibration was run.")
    else:
        r = d.recalibrated
        lines += [f"Recalibrated with **{r['label']}** on the {' and '.join(d.fit_on)} features ({', '.join(r['fitted_on'])}): "
                  + "; ".join(filter(None, [
                      ", ".join(f"{k} = {v:.4g}" for k, v in r["params"].items()),
                      ", ".join(f"{k} = {v:.3g} (95 % interval {r['effect_interval'][k][0]:.3g} to "
                                f"{r['effect_interval'][k][1]:.3g})" for k, v in r["effect_values"].items())]))
                  + " (the posterior mean; the best fit, "
                  + ", ".join(f"{k} = {v:.4g}" for k, v in r.get("best_fit", {}).items()) + ", lies on the ridge "
                  "the fit features leave).", "",
                  f"Judged on the held-out features ({', '.join(d.judge_on)}), with fresh seeds:", "",
                  *_before_after(d), "", shrinkage_text(d)]
    lines += ["", f"z = (simulation − experiment) / √(s_exp²/n_exp + s_sim²/n_sim); |z| > {IMPLAUSIBLE_Z:g} is "
              "implausible. s_sim is one simulation's seed s.d. from the design's residuals (from its replicates' "
              "scatter where the design's emulator misfits the feature); s_exp is the replicates' s.d., never "
              "below s_sim."]
    return "\n".join(lines) + "\n"


def _emulator_findings(d: Diagnosis) -> list[str]:
    """Where the design's emulator misfits (a finding of its own) and each effect's scale at the
    target ([] where neither)."""
    out = []
    if d.lack_of_fit:
        rows = "; ".join(f"{k} (residual s.d. {v['residual_sd']:.3g} against the replicates' {v['pure_error_sd']:.3g}, "
                         f"p = {v['p']:.2g})" for k, v in d.lack_of_fit.items())
        out += ["", f"**The design's emulator misfits** {rows}: its response there is beyond a quadratic, so those "
                "features' gaps are judged by the replicates' scatter and the misfit counts as the emulator's own "
                "error in the scores. A design box closer to the answer, or more points, reads them better."]
    if d.level_scale or d.own_signature:
        out += ["", "**At the target**, measured by one simulation each: "
                + level_words(d.level_scale, d.own_signature) + "."]
    return out


def _confirmations(d: Diagnosis) -> list[str]:
    """The baseline's test and each candidate's confirmation, in words."""
    out = []
    if d.final.baseline is not None:
        b = d.final.baseline.words()
        out += [b[:1].upper() + b[1:] + ".", ""]
    if d.ranking.verdict != d.verdict:
        out += [f"The design's ranking alone would have said: {d.ranking.reason}.", ""]
    for c in d.final.confirmations:
        w = c.words()
        out += [f"- **{c.outcome}**: {w[:1].upper() + w[1:]}."]
    return out + ([""] if d.final.confirmations else [])


def _metric_line(d: Diagnosis) -> list[str]:
    """The campaign metric's own verdict at its answer, beside the features' (they may differ: a
    metric on a few pooled features with a wide threshold can pass what single features do not)."""
    g = d.metric_gap
    if not g or not all(math.isfinite(g.get(k, math.nan)) for k in ("predicted", "threshold")):
        return []
    within = "within" if g["predicted"] <= g["threshold"] else "beyond"
    return [f"The campaign's metric put its answer at d = {g['predicted']:.3g} ± {g.get('predicted_sd', math.nan):.2g}, "
            f"{within} its noise threshold {g['threshold']:.3g}. Feature by feature (* held out of the "
            f"recalibration):", ""]


def _gap_table(rows: list[FeatureGap], judge: list[str]) -> list[str]:
    out = ["| feature | group | experiment (n) | simulation (n) | difference ± s.e. | z |", "|---|---|---|---|---|---|"]
    for g in rows:
        flag = " **implausible**" if g.implausible else ""
        out.append(f"| {g.name}{' *' if g.name in judge else ''} | {g.group} | {_fmt(g.experiment_mean)} ± "
                   f"{_fmt(g.experiment_sd)} ({g.n_experiment}) | {_fmt(g.sim_mean)} ± {_fmt(g.sim_sd)} ({g.n_sim}) | "
                   f"{_fmt(g.difference)} ± {_fmt(g.stderr)} | {g.z:+.2f}{flag} |")
    return out


def _before_after(d: Diagnosis) -> list[str]:
    after = {g.name: g for g in d.after}
    out = ["| feature | before: difference ± s.e. (z) | after: difference ± s.e. (z) |", "|---|---|---|"]
    for g in d.held_out("before"):
        a = after.get(g.name)
        out.append(f"| {g.name} | {_fmt(g.difference)} ± {_fmt(g.stderr)} ({g.z:+.2f}) | "
                   + (f"{_fmt(a.difference)} ± {_fmt(a.stderr)} ({a.z:+.2f}) |" if a else "– |"))
    return out


def figures(d: Diagnosis, calibrated: Calibrated, out: Path) -> list[str]:
    """Draw the three figures (PNG and SVG); return the file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from calibrax.report.figures import save_figure

    files: list[str] = []
    names = [g.name for g in d.before]
    fig, ax = plt.subplots(figsize=(7, 0.45 * len(names) + 1.5))
    ypos = np.arange(len(names))
    ax.axvspan(-IMPLAUSIBLE_Z, IMPLAUSIBLE_Z, color="0.92")
    ax.barh(ypos + 0.18, [g.z for g in d.before], height=0.35, color="tab:blue", label="before (calibrated)")
    after = {g.name: g.z for g in d.after}
    if after:
        ax.barh(ypos - 0.18, [after.get(n, np.nan) for n in names], height=0.35, color="tab:orange",
                label=f"after ({d.recalibrated.get('label', '')} added)")
    ax.set_yticks(ypos, [n + (" *" if n in d.judge_on else "") for n in names])
    ax.axvline(0, color="k", lw=0.6)
    ax.set_xlabel("z = (simulation − experiment) / s.e.")
    ax.invert_yaxis()
    ax.legend(fontsize=8, loc="best")
    ax.set_title("Where the gap lies (* held out of the recalibration)", fontsize=10)
    files += save_figure(fig, out, "diagnosis_residuals")

    fig, ax = plt.subplots(figsize=(7, 0.55 * len(d.ranking.models) + 1.6))
    none = next(m for m in d.ranking.models if m.name == NO_EFFECT)
    labels = [m.label for m in d.ranking.models]
    log_bf = np.array([(m.log_evidence - none.log_evidence) / math.log(10) for m in d.ranking.models])
    colours = ["tab:green" if m.name == d.verdict else "0.6" for m in d.ranking.models]
    ax.barh(labels, log_bf, color=colours)
    ax.axvline(math.log10(MIN_BAYES_FACTOR), color="k", ls="--", lw=0.8)
    ax.axvline(0, color="k", lw=0.6)
    span = max(np.ptp(np.append(log_bf, [0, math.log10(MIN_BAYES_FACTOR)])), 1.0)
    for k, (m, x) in enumerate(zip(d.ranking.models, log_bf)):
        ax.text(max(x, 0) + 0.02 * span, k, f"p = {m.probability:.2f}, max |z| = {m.max_abs_z:.1f}", va="center",
                fontsize=8)
    ax.set_xlim(min(log_bf.min(), 0) - 0.05 * span, max(log_bf.max(), math.log10(MIN_BAYES_FACTOR)) + 0.45 * span)
    ax.invert_yaxis()
    ax.set_xlabel(f"log₁₀ Bayes factor against no effect (dashed: {MIN_BAYES_FACTOR:g}, the least a finding needs)")
    ax.set_title(f"Which effect: {headline(d).split(' (')[0]}", fontsize=10)
    files += save_figure(fig, out, "diagnosis_scores")
    files += _curves(d, calibrated, out, plt, save_figure)
    return files


def _curves(d: Diagnosis, calibrated: Calibrated, out: Path, plt, save) -> list[str]:
    from calibrax.core.running.store import CampaignStore
    from calibrax.core.search.records import Status

    def results(path: Path) -> list:
        if not path.is_file():
            return []
        store = CampaignStore(path)
        p = store.points()[0]
        return [store.result(p.id, s.index) for s in p.sims if s.status == Status.DONE]

    before = results(out / d.stores.get("design", "design.h5"))
    after = results(out / d.stores["confirm"]) if "confirm" in d.stores else []
    if not before:
        return []
    steps = [s.target_stress for s in before[0].steps if s.kind == "shear"]
    fig, axes = plt.subplots(1, len(steps), figsize=(3.0 * len(steps), 3.4), sharey=True, squeeze=False)
    exp = calibrated.experiment
    for ax, sigma in zip(axes[0], steps):
        for (rep, s), (rot, tau) in exp.curves.items():
            if abs(s - sigma) < 1.0:
                ax.plot(rot, tau / 1e3, color="k", lw=1.0, alpha=0.8, label="experiment")
        for group, colour, name in ((before, "tab:blue", "before"), (after, "tab:orange", "after")):
            for r in group:
                step = next(st for st in r.steps if st.kind == "shear" and abs(st.target_stress - sigma) < 1.0)
                ax.plot(step.rotation, step.shear_stress / 1e3, color=colour, lw=0.7, alpha=0.6, label=name)
        ax.set_title(f"σ = {sigma / 1e3:g} kPa", fontsize=9)
        ax.set_xlabel("head rotation [rad]")
        ax.grid(alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    unique = dict(zip(labels, handles))
    axes[0][0].legend(unique.values(), unique.keys(), fontsize=7)
    axes[0][0].set_ylabel("τ [kPa]")
    if not exp.curves:
        fig.text(0.5, 0.01, "the experiment has no τ curves", ha="center", fontsize=8)
    return save(fig, out, "diagnosis_curves")


def write_diagnosis_report(d: Diagnosis, calibrated: Calibrated, out: Path) -> tuple[str, list[str]]:
    """Write ``diagnosis.md`` and the figures into ``out``; return the text and the figure files."""
    text = markdown(d)
    files = figures(d, calibrated, out)
    pngs = [f for f in files if f.endswith(".png")]
    body = text + "\n" + "\n".join(f"![{Path(f).stem}]({f})\n\n*{CAPTIONS[Path(f).stem]}*\n" for f in pngs)
    (out / "diagnosis.md").write_text(body, encoding="utf-8")
    return text, files
