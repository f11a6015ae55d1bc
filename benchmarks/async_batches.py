"""Synchronous against asynchronous q = 2 batches on the same budget, with simulations of uneven
duration. Prints worker utilisation and wall time to a given distance, medians over repeats,
side by side from one run.

    .venv/bin/python benchmarks/async_batches.py [--repeats 3] [--sleep 2-8] [--workers 2]

The backend is the analytic TEST DOUBLE of the test suite (tests/doubles), whose simulations sleep
for a seeded, uneven time: this measures the scheduling, not a DEM engine.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ["CALIBRAX_PLUGINS"] = "tests.doubles.analytic_simulator"
os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])


def one_run(batching: str, seed: int, workers: int, threshold: float) -> dict[str, float]:
    from calibrax import load_config, run_campaign
    from tests.conftest import write_double_campaign

    events = []
    with tempfile.TemporaryDirectory() as tmp:
        config = load_config(write_double_campaign(Path(tmp), seed=seed, budget={"initial": 4, "iterations": 6},
                                                   acquisition={"name": "qei", "q": 2, "batching": batching},
                                                   executor={"name": "local", "workers": workers}))
        t0 = time.monotonic()
        run_campaign(config, events.append)
        wall = time.monotonic() - t0
    busy = sum(e["wall_s"] for e in events if e["event"] in ("done", "failed"))
    reached = [e["time"] for e in events if e["event"] == "done" and (e.get("best_distance") or 1e9) <= threshold]
    start = events[0]["time"]
    return {"wall_s": wall, "utilisation": busy / (workers * wall),
            "to_threshold_s": (reached[0] - start) if reached else float("nan"),
            "best": min((e["best_distance"] for e in events if e["event"] == "done" and e.get("best_distance")),
                        default=float("nan"))}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--sleep", default="2-8", help="simulation duration range, seconds (A-B)")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--threshold", type=float, default=2.0, help="distance to reach")
    args = p.parse_args()
    os.environ["CALIBRAX_DOUBLE_SLEEP"] = args.sleep
    import logging

    logging.disable(logging.INFO)
    rows: dict[str, list[dict[str, float]]] = {"sync": [], "async": []}
    for r in range(args.repeats):
        for mode in ("sync", "async"):  # interleaved so that machine noise hits both alike
            rows[mode].append(one_run(mode, seed=r, workers=args.workers, threshold=args.threshold))
            print(f"repeat {r} {mode:>5}: " + ", ".join(f"{k} {v:.3g}" for k, v in rows[mode][-1].items()), flush=True)
    print(f"\n16 simulations (4 initial + 6 × q=2), {args.workers} workers, durations {args.sleep} s, "
          f"medians of {args.repeats} repeats")
    print(f"{'':<24}{'sync':>10}{'async':>10}{'async/sync':>12}")
    for key, name in (("wall_s", "campaign wall [s]"), ("utilisation", "worker utilisation"),
                      ("to_threshold_s", f"wall to d ≤ {args.threshold:g} [s]"), ("best", "best distance")):
        s = statistics.median(r[key] for r in rows["sync"])
        a = statistics.median(r[key] for r in rows["async"])
        print(f"{name:<24}{s:>10.3g}{a:>10.3g}{a / s:>12.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
