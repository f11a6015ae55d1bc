"""Where numba_dem's time goes on the shear-cell workloads of ``dem_throughput.py``: µs per
particle-step of each part of a time step, one thread.

Parts (each timed on its own, on the same state, as the minimum over ``--rounds`` rounds of
``--calls`` calls; the machine's noise inflates medians, not minima):
  * ``pairs, open``: the pair kernel (``engine.pair_forces``) on the listed pairs when none
    touches (radii halved): the list walk, the distance test and the clearing of open pairs;
  * ``pairs, normal``: the same kernel with the true radii but no friction, minus the above: the
    Hertz normal force with damping of the touching pairs;
  * ``pairs, sliding`` and ``pairs, rolling``: what the tangential spring, then the rolling spring,
    add to it;
  * ``integration``: the gather pass (``engine.gather_kick_drift``) without walls, head or partner
    shares: the kick, the drift and the list-displacement check;
  * ``partner shares``: what the partner's share of each pair adds to the gather;
  * ``walls, base, ribs, head``: what the analytic boundaries add to it (the vessel, the base and
    its ribs, the head's disc and blades);
  * ``list builds``: one neighbour-list rebuild times the builds per step of a ``--steps`` run.

It also prints the pairs listed and touching per particle, the wall contacts per particle and the
total per step from that run, to compare with the parts' sum. Use it before and after a change to
the kernels; ``dem_throughput.py`` compares the engines.

Example: python benchmarks/dem_profile.py --preset quick
"""

from __future__ import annotations

import argparse
import copy
import time
from collections.abc import Callable

import numpy as np

from calibrax.core.sheartest import ShearCellSpec
from calibrax_numba_dem.engine import GATHER_BLOCKS, DEMSystem, gather_kick_drift, numba_threads, pair_forces
from calibrax_numba_dem.geometry import element_directions
from calibrax_numba_dem.layout import (P_MU, P_MUR, P_NBLADES, P_NRIBS, P_USE_BASE, P_USE_CYL, P_USE_HEAD,
                                       W_SIZE)
from dem_throughput import prepare


def best_time(call: Callable[[], None], calls: int, rounds: int, per: int) -> float:
    """Minimum over ``rounds`` of the µs per call and per ``per`` particles of ``calls`` calls."""
    best = float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(calls):
            call()
        best = min(best, (time.perf_counter() - t0) / calls / per * 1e6)
    return best


def pair_kernel_time(s: DEMSystem, rad: np.ndarray, params: np.ndarray, calls: int, rounds: int) -> float:
    """µs per particle of one pair-kernel pass on ``s`` with radii ``rad`` and ``params`` (on copies
    of the pair history, so the state is left as it was)."""
    fo = np.zeros((s.n, 6))
    hist, rhist, pf = s.hist.copy(), s.rhist.copy(), s.pf.copy()
    return best_time(lambda: pair_forces(s.x, s.v, s.w, rad, s.mass, s.start, s.pj, s.pimg, hist, rhist, params, pf,
                                         fo),
                     calls, rounds, s.n)


def gather_time(s: DEMSystem, params: np.ndarray, partners: bool, calls: int, rounds: int) -> float:
    """µs per particle of one gather pass on a copy of ``s`` with ``params`` (kick 0: nothing moves
    but the wall-contact slots), with or without the partner shares."""
    c = copy.deepcopy(s)
    dirs = np.zeros((max(1, int(params[P_NBLADES]) + int(params[P_NRIBS])), 2))
    element_directions(params, c.head, dirs)
    fo = np.zeros((c.n, 6))
    part = np.empty((min(GATHER_BLOCKS, c.n), W_SIZE + 1))
    rstart = c.rstart if partners else np.zeros_like(c.rstart)
    return best_time(lambda: gather_kick_drift(c.x, c.v, c.w, c.f, c.t, c.rad, c.mass, c.inertia, rstart, c.rpair,
                                               c.pf, fo, params, c.head, dirs, c.wid, c.whist, c.wrhist,
                                               c.x_build, 0.0, part), calls, rounds, c.n)


def contacts_per_particle(s: DEMSystem) -> tuple[float, float, float]:
    """(pairs listed, pairs touching, wall contacts) per particle in state ``s``."""
    owner = np.repeat(np.arange(s.n), np.diff(s.start))
    partner = s.pj[:s.pair_count]
    gap = np.linalg.norm(s.x[owner] - s.x[partner], axis=1) - s.rad[owner] - s.rad[partner]
    return s.pair_count / s.n, float(np.sum(gap < 0)) / s.n, float(np.sum(s.wid >= 0)) / s.n


def profile(s0: DEMSystem, steps: int, calls: int, rounds: int) -> dict[str, float]:
    """The parts of a time step of ``s0`` (see the module's docstring), µs per particle-step."""
    s = copy.deepcopy(s0)
    builds0 = s.list_builds
    t0 = time.perf_counter()
    s.advance(steps)
    total = (time.perf_counter() - t0) / steps / s.n * 1e6
    builds = (s.list_builds - builds0) / steps
    p = s.params
    no_friction = p.copy()
    no_friction[[P_MU, P_MUR]] = 0.0
    no_rolling = p.copy()
    no_rolling[P_MUR] = 0.0
    t_open = pair_kernel_time(s, 0.5 * s.rad, p, calls, rounds)
    t_normal = pair_kernel_time(s, s.rad, no_friction, calls, rounds)
    t_sliding = pair_kernel_time(s, s.rad, no_rolling, calls, rounds)
    t_all = pair_kernel_time(s, s.rad, p, calls, rounds)
    no_walls = p.copy()
    no_walls[[P_USE_CYL, P_USE_BASE, P_USE_HEAD, P_NRIBS]] = 0.0
    g_bare = gather_time(s, no_walls, False, calls, rounds)
    g_partners = gather_time(s, no_walls, True, calls, rounds)
    g_all = gather_time(s, p, True, calls, rounds)
    r = copy.deepcopy(s)
    t_build = best_time(r.rebuild_lists, max(1, calls // 10), rounds, r.n)
    return {"pairs, open": t_open, "pairs, normal": t_normal - t_open, "pairs, sliding": t_sliding - t_normal,
            "pairs, rolling": t_all - t_sliding, "integration": g_bare, "partner shares": g_partners - g_bare,
            "walls, base, ribs, head": g_all - g_partners, "list builds": t_build * builds,
            "(run of --steps steps)": total}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="quick", choices=["tiny", "quick", "paper"])
    ap.add_argument("--steps", type=int, default=2000, help="steps of the whole-step run (default 2000)")
    ap.add_argument("--calls", type=int, default=200, help="calls per part and round (default 200)")
    ap.add_argument("--rounds", type=int, default=9, help="rounds per part, minimum reported (default 9)")
    args = ap.parse_args()
    spec = ShearCellSpec.preset(args.preset)
    bed, sheared = prepare(spec, True)
    bed.params[P_USE_HEAD] = 0.0
    with numba_threads(1):
        bed.advance(300)
        for name, s in (("bed", bed), ("preshear", sheared)):
            listed, touching, walls = contacts_per_particle(s)
            parts = profile(s, args.steps, args.calls, args.rounds)
            total = parts.pop("(run of --steps steps)")
            print(f"{args.preset} {name}: {s.n} particles; per particle {listed:.2f} pairs listed, {touching:.2f} "
                  f"touching, {walls:.2f} wall contacts; whole step {total:.4f} µs/particle-step (1 thread)")
            for part, us in parts.items():
                print(f"  {part:26s} {us:8.4f}  {100 * us / total:5.1f} %")
            print(f"  {'sum of the parts':26s} {sum(parts.values()):8.4f}  {100 * sum(parts.values()) / total:5.1f} %")


if __name__ == "__main__":
    main()
