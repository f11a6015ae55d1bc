"""`calibrax report` builds every figure and an HTML page that references them, also for a store
with failed simulations; `calibrax run --json` streams machine-readable progress."""

from __future__ import annotations

import csv
import json
import re

from calibrax import trial_rows
from tests.conftest import calibrax_cli, double_env, write_double_campaign

FIGURES = ("cartography", "yield_loci", "shear_curves", "surrogate", "convergence")


def check_report(folder):
    page = (folder / "index.html").read_text()
    referenced = set(re.findall(r"(?:src|href)='([^']+)'", page))
    for stem in FIGURES:
        for ext in ("png", "svg"):
            assert (folder / f"{stem}.{ext}").stat().st_size > 1000, f"{stem}.{ext} missing or empty"
            assert f"{stem}.{ext}" in referenced, f"index.html does not reference {stem}.{ext}"
    assert all((folder / name).exists() for name in referenced)
    summary = (folder / "summary.md").read_text()
    assert "Best observed point" in summary and "**Answer.** " in summary and "Recommended: " in summary
    return page, summary


def test_report_of_a_campaign_with_json_progress(tmp_path):
    path = write_double_campaign(tmp_path, budget={"initial": 4, "iterations": 2})
    proc = calibrax_cli("run", str(path), "--json")
    assert proc.returncode == 0, proc.stderr
    events = [json.loads(line) for line in proc.stdout.splitlines()]
    kinds = [e["event"] for e in events]
    assert kinds[0] == "campaign" and kinds[-1] == "summary"
    assert kinds.count("started") == kinds.count("done") == 8 and kinds.count("model") == 2
    done = [e for e in events if e["event"] == "done"]
    assert all(e["seed"] >= 0 and len(e["peaks_pa"]) == 4 for e in done)
    assert events[-1]["points"] == 8 and events[-1]["best_id"] is not None
    out = tmp_path / "report"
    # an empty matplotlib config folder: matplotlib builds its font cache and logs so at INFO level
    rep = calibrax_cli("report", str(tmp_path / "runs/double.h5"), "-o", str(out),
                       env=double_env(MPLCONFIGDIR=str(tmp_path / "mpl")))
    assert rep.returncode == 0, rep.stderr
    assert "fontManager" not in rep.stderr, rep.stderr  # a user's page, not matplotlib's housekeeping
    page, summary = check_report(out)
    # "within the noise" is the metric's stated threshold, not d ≤ 1
    assert "noise threshold " in summary and "met by the truth 95% of the time" in summary
    assert "the noise (threshold d = " in summary  # the best point's line: within or outside
    assert "no failed simulation" in page and "class='failed'" not in page  # nothing in red when nothing failed


def test_report_of_a_store_with_failed_simulations(tmp_path):
    path = write_double_campaign(tmp_path, budget={"initial": 6, "iterations": 1})
    proc = calibrax_cli("run", str(path), env=double_env(CALIBRAX_DOUBLE_FAULT="fail:0.6"))
    assert proc.returncode == 0, proc.stderr
    assert "FAILED" in proc.stderr and "double told to fail" in proc.stderr
    status = calibrax_cli("status", str(tmp_path / "runs/double.h5"))
    assert "failed [unstable]" in status.stdout
    # the experiment's targets and the distance's scales, so that a large d can be read
    assert "experiment: C = " in status.stdout and "with scales C " in status.stdout, status.stdout
    # the trials as CSV (issue 21): one row per point, failures as data, empty cells where unknown
    exported = calibrax_cli("export", str(tmp_path / "runs/double.h5"), "-o", str(tmp_path / "trials.csv"))
    assert exported.returncode == 0 and "written:" in exported.stdout, exported.stderr
    with open(tmp_path / "trials.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(trial_rows(tmp_path / "runs/double.h5")) == 6 + 2
    failed = [r for r in rows if r["state"] == "failed"]
    assert failed and all("double told to fail" in r["failures"] and r["distance"] == "" for r in failed), failed
    done = [r for r in rows if r["state"] == "done"]
    assert done and all(float(r["distance"]) >= 0 and float(r["youngs_modulus_Pa"]) >= 5e9 for r in done)
    assert [r["best"] for r in rows].count("True") == 1 and "peak_tau_9kPa_Pa" in rows[0]
    rep = calibrax_cli("report", str(tmp_path / "runs/double.h5"), "-o", str(tmp_path / "r"))
    assert rep.returncode == 0, rep.stderr
    page, summary = check_report(tmp_path / "r")
    assert "Failed simulations" in page and "double told to fail" in page and "double log tail" in page
    assert "## Failed simulations" in summary


def test_report_help_says_where_the_figures_are():
    proc = calibrax_cli("report", "--help")
    assert proc.returncode == 0 and "self-contained" not in proc.stdout and "share the folder" in proc.stdout


def test_report_of_a_missing_store_is_a_clear_error(tmp_path):
    proc = calibrax_cli("report", str(tmp_path / "nope.h5"))
    assert proc.returncode == 2 and "not found" in proc.stderr and "Traceback" not in proc.stderr


def test_single_file_report_opens_alone_in_a_real_browser(tmp_path):
    """`report --single-file` writes one HTML file that a browser shows with every figure, with no
    other file beside it (issue 36: engineers mail reports)."""
    from tests.browser import page_images

    path = write_double_campaign(tmp_path, budget={"initial": 4, "iterations": 1})
    assert calibrax_cli("run", str(path), "--quiet").returncode == 0
    mail = tmp_path / "mail"
    mail.mkdir()
    rep = calibrax_cli("report", str(tmp_path / "runs/double.h5"), "--single-file", "-o", str(mail))
    assert rep.returncode == 0, rep.stderr
    assert [p.name for p in mail.iterdir()] == ["double.report.html"], list(mail.iterdir())
    assert str(mail / "double.report.html") in rep.stdout
    alone = tmp_path / "inbox" / "report.html"      # moved where nothing else lies, as an attachment is
    alone.parent.mkdir()
    (mail / "double.report.html").rename(alone)
    page = alone.read_text()
    addresses = re.findall(r"(?:src|href)='([^']*)'", page)
    assert addresses and all(a.startswith("data:") for a in addresses), [a[:40] for a in addresses]
    assert "Best observed point" in page and "<b>Answer.</b>" in page
    images = page_images(alone)
    assert sorted(i["alt"] for i in images) == sorted(FIGURES), images
    assert all(i["scheme"] == "data" and i["width"] > 100 and i["height"] > 100 for i in images), images
    # the default file name sits beside the store; the folder report is untouched by it
    default = calibrax_cli("report", str(tmp_path / "runs/double.h5"), "--single-file")
    assert default.returncode == 0 and (tmp_path / "runs/double.report.html").is_file()
    assert not (tmp_path / "runs/double.report").exists()


def test_report_of_a_one_parameter_campaign(tmp_path):
    """The quickstart calibrates μs alone: its report builds every figure, the 1-D surrogate figure
    with the threshold and the ruled-out region (issue 51)."""
    path = write_double_campaign(tmp_path, parameters={"sliding_friction": {"low": 0.1, "high": 0.9}},
                                 budget={"initial": 4, "iterations": 1})
    proc = calibrax_cli("run", str(path), "--quiet")
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "report"
    rep = calibrax_cli("report", str(tmp_path / "runs/double.h5"), "-o", str(out))
    assert rep.returncode == 0, rep.stderr
    _, summary = check_report(out)
    assert "μs" in summary.split("**Answer.** ")[1] and "E " not in summary.split("**Answer.** ")[1].split(".")[0]
    svg = (out / "surrogate.svg").read_text()
    assert "noise threshold d = " in svg and "recommendation" in svg
