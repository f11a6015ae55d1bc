"""``calibrax report``: an HTML page with its PNG/SVG figures beside it and a Markdown summary (a
folder: copy the folder to share it), or one HTML file with the figures embedded (``--single-file``:
mail it, it opens with no other file beside it)."""

from __future__ import annotations

import base64
import html
import math
import os
import tempfile
from pathlib import Path
from typing import Callable

from calibrax.core.search.summary import noise_text
from calibrax.report import figures
from calibrax.report.data import CampaignData, load_campaign

__all__ = ["build_report", "build_single_file_report", "load_campaign", "CampaignData"]

CAPTIONS = {
    "cartography": "C–AIF cartography (the paper's figure 4): simulated points with regression error bars, "
                   "iso-parameter lines from Kriging models of C and AIF, the experiment with its replicate spread.",
    "yield_loci": "Yield loci of the experiment and the best simulations.",
    "shear_curves": "Shear steps of the best point: τ and σ against the head's rotation, experiment where given.",
    "surrogate": "Kriging surrogate of the distance: prediction and its standard deviation.",
    "convergence": "Best distance against the number of simulations; wall time per point.",
}


def build_report(store: str | Path, out_dir: str | Path | None = None) -> Path:
    """Write ``index.html``, ``summary.md`` and the figures (PNG and SVG) into ``out_dir`` (default
    ``STORE.report/``); return the HTML path. The page refers to the figure files beside it."""
    data = load_campaign(store)
    out = Path(out_dir) if out_dir is not None else data.store.with_suffix(".report")
    out.mkdir(parents=True, exist_ok=True)
    files, statement = _figures(data, out)
    diagnosis = _diagnosis(data.store)
    for figure in _diagnosis_figures(data.store):
        (out / figure.name).write_bytes(figure.read_bytes())
    (out / "summary.md").write_text(_markdown(data, statement) + (f"\n{diagnosis}" if diagnosis else ""),
                                    encoding="utf-8")
    page = out / "index.html"
    page.write_text(_html(data, files, statement, diagnosis), encoding="utf-8")
    return page


def build_single_file_report(store: str | Path, out_file: str | Path | None = None) -> Path:
    """Write the report as one HTML file (default ``STORE.report.html``) with every figure embedded
    as a PNG data URI, so that it opens with no other file beside it (to mail or attach); return its
    path. The figures are drawn in a temporary folder; the file is written whole or not at all."""
    data = load_campaign(store)
    out = Path(out_file) if out_file is not None else data.store.with_suffix(".report.html")
    if out.is_dir():
        out = out / data.store.with_suffix(".report.html").name
    out.parent.mkdir(parents=True, exist_ok=True)
    diagnosis = _diagnosis(data.store)
    embedded = {figure.name: figure for figure in _diagnosis_figures(data.store)}
    with tempfile.TemporaryDirectory(prefix="calibrax-report-") as tmp:
        files, statement = _figures(data, Path(tmp))
        files = {key: [n for n in names if n.endswith(".png")] for key, names in files.items()}
        embedded.update({n: Path(tmp) / n for names in files.values() for n in names})
        page = _html(data, files, statement, diagnosis, url=lambda name: _data_uri(embedded[name]) if name in embedded else name)
    partial = out.with_name(f".{out.name}.tmp")
    partial.write_text(page, encoding="utf-8")
    os.replace(partial, out)
    return out


def _figures(data: CampaignData, folder: Path) -> tuple[dict[str, list[str]], str]:
    """Draw every figure into ``folder``: {figure key: its file names}, and the surrogate's
    statement of the parameter ranges predicted within the noise."""
    files: dict[str, list[str]] = {}
    files["cartography"] = figures.cartography(data, folder)
    files["yield_loci"] = figures.yield_loci(data, folder)
    files["shear_curves"] = figures.shear_curves(data, folder)
    files["surrogate"], statement = figures.surrogate_maps(data, folder)
    files["convergence"] = figures.convergence(data, folder)
    return files, statement


def _data_uri(path: Path) -> str:
    """A figure file as a data URI (PNG or SVG)."""
    mime = {".png": "image/png", ".svg": "image/svg+xml"}[path.suffix]
    return f"data:{mime};base64,{base64.b64encode(path.read_bytes()).decode('ascii')}"


def _diagnosis(store: Path) -> str:
    """The store's diagnosis summary (``calibrax diagnose`` into STORE.diagnosis/); "" when there is none."""
    summary = Path(store).with_suffix(".diagnosis") / "diagnosis.md"
    return summary.read_text(encoding="utf-8") if summary.is_file() else ""


def _diagnosis_figures(store: Path) -> list[Path]:
    """The diagnosis' figure files its summary refers to (PNG and SVG); none without a diagnosis."""
    folder = Path(store).with_suffix(".diagnosis")
    if not (folder / "diagnosis.md").is_file():
        return []
    return sorted(f for f in folder.glob("diagnosis_*.*") if f.suffix in (".png", ".svg"))


def _best_line(data: CampaignData) -> str:
    b = data.best
    if b is None:
        return "No point has finished yet."
    params = ", ".join(f"{figures.label(n)} = {figures.scaled(n, v):.4g}" for n, v in b.record.params().items())
    m = b.record.metric
    return (f"Best observed point {b.id} (one draw of the noise, not the answer): {params}; "
            f"distance {b.distance:.3g} ± {m.uncertainty:.2g}, "
            f"{noise_text(b.distance, m.threshold, m.threshold_rate)}; "
            f"C = {b.cohesion:.0f} ± {b.cohesion_stderr:.0f} Pa, AIF = {b.aif:.1f} ± {b.aif_stderr:.1f}°.")


def _rows(data: CampaignData) -> list[list[str]]:
    rows = []
    for p in data.points:
        params = [f"{figures.scaled(n, v):.4g}" for n, v in p.record.params().items()]
        fin = math.isfinite
        rows.append([str(p.id), str(p.record.batch), p.record.acquisition, *params, p.record.status,
                     f"{p.cohesion:.0f}" if fin(p.cohesion) else "", f"{p.aif:.1f}" if fin(p.aif) else "",
                     f"{p.distance:.3g}" if fin(p.distance) else "", f"{p.wall_time:.1f}"])
    return rows


def _header(data: CampaignData) -> list[str]:
    return ["point", "batch", "proposed by", *[figures.label(n) for n in data.space.names], "status", "C [Pa]",
            "AIF [°]", "distance", "wall [s]"]


def _markdown(data: CampaignData, statement: str) -> str:
    cfg = data.config
    lines = [f"# Campaign {cfg['name']}", "",
             f"Simulator `{cfg['simulator']}`, acquisition `{cfg['acquisition']['name']}` (q = {cfg['acquisition']['q']}), "
             f"{len(data.points)} points, {len(data.done)} finished, {len(data.failures)} failed simulation(s).", "",
             f"**Answer.** {statement}", "", _best_line(data), "", "| " + " | ".join(_header(data)) + " |",
             "|" + "---|" * len(_header(data))]
    lines += ["| " + " | ".join(r) + " |" for r in _rows(data)]
    if data.failures:
        lines += ["", "## Failed simulations", ""]
        lines += [f"- point {p.id} sim {i} [{kind}]: {reason}" for p, i, kind, reason, _ in data.failures]
    if data.experiment is not None and data.experiment.source:
        lines += ["", "## Experiment", "", data.experiment.source]
    return "\n".join(lines) + "\n"


def _html(data: CampaignData, files: dict[str, list[str]], statement: str, diagnosis: str = "",
          url: Callable[[str], str] = str) -> str:
    """The report page; ``url`` turns a figure's file name into the address the page uses (the name
    itself beside the page, or a data URI in a single file). A figure without an SVG gets no SVG link."""
    e = html.escape
    cfg = data.config
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>calibrax: {e(cfg['name'])}</title>",
             "<style>body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}"
             "table{border-collapse:collapse;font-size:90%}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}"
             "figure{margin:1.5em 0}figcaption{color:#444;font-size:90%}img{max-width:100%}"
             ".failed{color:#b00}pre{background:#f4f4f4;padding:.5em;overflow:auto;font-size:80%}</style></head><body>",
             f"<h1>Campaign {e(cfg['name'])}</h1>",
             f"<p>Simulator <b>{e(cfg['simulator'])}</b>, acquisition <b>{e(cfg['acquisition']['name'])}</b> "
             f"(q = {cfg['acquisition']['q']}); {len(data.points)} points, {len(data.done)} finished, "
             + (f"<span class='failed'>{len(data.failures)} failed simulation(s)</span>" if data.failures
                else "no failed simulation") + f". Store: <code>{e(str(data.store))}</code></p>",
             f"<p><b>Answer.</b> {e(statement)}</p>", f"<p>{e(_best_line(data))}</p>"]
    for key, names in files.items():
        png = [n for n in names if n.endswith(".png")]
        if png:
            svg = [n for n in names if n.endswith(".svg")]
            link = f" (<a href='{e(url(svg[0]))}'>SVG</a>)" if svg else ""
            parts.append(f"<figure><img src='{e(url(png[0]))}' alt='{e(key)}'><figcaption>{e(CAPTIONS[key])}{link}"
                         "</figcaption></figure>")
    parts.append("<h2>Points</h2><table><tr>" + "".join(f"<th>{e(h)}</th>" for h in _header(data)) + "</tr>")
    for row in _rows(data):
        cls = " class='failed'" if "failed" in row else ""
        parts.append(f"<tr{cls}>" + "".join(f"<td>{e(c)}</td>" for c in row) + "</tr>")
    parts.append("</table>")
    if data.failures:
        parts.append("<h2 class='failed'>Failed simulations</h2>")
        for p, i, kind, reason, tail in data.failures:
            parts.append(f"<details><summary>point {p.id} sim {i} [{e(kind)}]: {e(reason)}</summary>"
                         f"<pre>{e(tail or '(no log)')}</pre></details>")
    if diagnosis:
        parts.append(_markdown_html(diagnosis, url))
    if data.experiment is not None:
        parts.append(f"<h2>Experiment</h2><p>{e(data.experiment.name)}</p><pre>{e(data.experiment.source)}</pre>")
    parts.append("</body></html>")
    return "\n".join(parts)


def _markdown_html(text: str, url: Callable[[str], str] = str) -> str:
    """The little Markdown a diagnosis summary uses (headings, tables, images, bold, paragraphs) as
    HTML; an image's file name goes through ``url`` as the page's figures do."""
    import re

    e = html.escape
    out, table = [], []

    def inline(s: str) -> str:
        return re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", e(s))

    def flush() -> None:
        if table:
            rows = [r for r in table if not set(r.replace("|", "").strip()) <= {"-", ""}]
            out.append("<table>" + "".join("<tr>" + "".join(f"<td>{inline(c.strip())}</td>" for c in r.strip("|").split("|"))
                                           + "</tr>" for r in rows) + "</table>")
            table.clear()

    for line in text.splitlines():
        if line.startswith("|"):
            table.append(line)
            continue
        flush()
        image = re.match(r"!\[(.*?)\]\((.*?)\)", line)
        if line.startswith("#"):
            level = min(len(line) - len(line.lstrip("#")) + 1, 4)
            out.append(f"<h{level}>{inline(line.lstrip('#').strip())}</h{level}>")
        elif image:
            out.append(f"<figure><img src='{e(url(image.group(2)))}' alt='{e(image.group(1))}'></figure>")
        elif line.startswith("*") and line.endswith("*") and not line.startswith("**"):
            out.append(f"<p><i>{e(line.strip('*'))}</i></p>")
        elif line.strip():
            out.append(f"<p>{inline(line)}</p>")
    flush()
    return "\n".join(out)
