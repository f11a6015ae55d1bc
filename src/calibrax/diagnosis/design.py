"""The DEM design a diagnosis runs: replicate seeds at the calibrated point, a few points around it
without any effect, and for each candidate a space-filling set over the calibrated parameters and
the effect's range.

The box around the calibrated point is where the joint fit may move the calibrated parameters:
an effect that adds strength is compensated by a lower μs, so the box must reach past the
campaign's plausible region. Each calibrated parameter spans its plausible interval, widened to at
least ``MIN_HALF_WIDTH`` of its range on either side of the recommendation, within its bounds;
where the top candidate's fit still stops at an edge, the box reaches past it once
(:meth:`Box.reach`, :func:`reach_points`).

Across fidelities (a multi-fidelity campaign), every point runs at the cheapest fidelity but the
target's replicates at the calibrated point, which come first (:func:`design_points` with ``cheap``),
and, for each candidate the diagnosis comes to rank first, one point at the target with the effect
at the middle of its range (:func:`level_point`): an effect's signature need not have the same size
at both levels (a rough wall drags the whole bed of a small cell, a thin band of a large one), and
that point gives its scale between them (:meth:`calibrax.diagnosis.scoring.Emulator.fit`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from calibrax.core.search.parameters import ParameterSpace
from calibrax.diagnosis.effects import Effect

#: the box's least half-width around the recommendation, as a fraction of each parameter's range
MIN_HALF_WIDTH = 0.15
#: seeds of diagnosis simulations start here: above any campaign's point-indexed seeds in practice,
#: below calibrax.core.data.pseudo.EXPERIMENT_SEED_BASE as every simulation seed is
SEED_BASE = 700_000_000
#: a diagnosis across fidelities runs this many replicates and as many confirmations at the target:
#: with the first candidate's point there, five tests of the converged cell (2 300–2 500 CPU-s each)
#: are 3.3 CPU-hours, and the default design at tiny (48 tests of 70 CPU-s) 0.9 more: above issue
#: 51's 4 CPU-hours, which the smaller design of benchmarks/diagnose_fidelities.py (21 at tiny) meets
TARGET_RUNS = 2
#: a diagnosis across fidelities gives at most this many candidates a point at the target (each
#: when it ranks first; as many as the verdict confirms in turn, ``verdict.MAX_TRIED``); the first
#: is usually the only one: at `converged`, 0.7 CPU-hours
LEVEL_POINTS = 2
#: the target replicates' seeds: above the design's, below the confirmations' (``+ 900``)
TARGET_SEED_OFFSET = 800
#: the seeds of each candidate's point at the target (:func:`level_point`): between the reach's and
#: the target replicates'
LEVEL_SEED_OFFSET = 700
#: a candidate's point at the target sets its parameters at this fraction of their range above off:
#: the middle, where a signature is well above the seeds' noise and short of the range's end
LEVEL_FRACTION = 0.5
#: the seeds of the points a reached box adds (:func:`reach_points`): above the design's
REACH_SEED_OFFSET = 600
#: a best fit within this share of the box's half-width of its edge is "at the edge" (scaled [−1, 1])
EDGE = 0.05


@dataclass(frozen=True)
class Budget:
    """How a diagnosis spends its simulations.

    Attributes:
        replicates: seeds at the calibrated point (the "before" of the gap).
        baseline: further points without any effect, spread over the box.
        per_effect: points per candidate effect.
        confirm: seeds at the recalibrated point with the top effect (the "after"); where its
            confirmation refutes it, the runner-up is confirmed with as many more
            (:data:`calibrax.diagnosis.verdict.MAX_TRIED` candidates at most), so a diagnosis
            runs :meth:`total` simulations when the top candidate holds and up to ``confirm``
            more otherwise.

        target_replicates: in a diagnosis across fidelities, seeds at the calibrated point at the
            target fidelity (the "before" there; ``replicates`` then run at the cheap one, like the
            rest of the design, and ``confirm`` at the target); 0 at one fidelity.
        level_points: in a diagnosis across fidelities, how many candidates get a point at the
            target (:func:`level_point`), each when it ranks first; 0 at one fidelity.
    """

    replicates: int = 4
    baseline: int = 4
    per_effect: int = 8
    confirm: int = 4
    target_replicates: int = 0
    level_points: int = 0

    def total(self, n_effects: int) -> int:
        return (self.replicates + self.baseline + n_effects * self.per_effect + self.confirm + self.target_replicates
                + self.level_points)

    @classmethod
    def for_total(cls, total: int, n_effects: int, target_runs: int = 0) -> "Budget":
        """The split of ``total`` simulations: 4 replicates and 4 confirmations (fewer below 24
        simulations), 4 baseline points, the rest shared evenly by the candidates. With
        ``target_runs`` (a diagnosis across fidelities) that many replicates and as many
        confirmations run at the target, the rest at the cheap fidelity."""
        small = total < 24
        replicates = confirm = 3 if small else 4
        baseline = 3 if small else 4
        level = LEVEL_POINTS if target_runs else 0
        if target_runs:
            confirm = target_runs
        per_effect = (total - replicates - confirm - baseline - target_runs - level) // max(n_effects, 1)
        return cls(replicates, baseline, per_effect, confirm, target_runs, level)

    @classmethod
    def across_fidelities(cls) -> "Budget":
        """The default budget of a diagnosis across fidelities: the default design at the cheap
        fidelity, :data:`TARGET_RUNS` replicates and as many confirmations at the target, and up to
        :data:`LEVEL_POINTS` candidates' points there."""
        return cls(confirm=TARGET_RUNS, target_replicates=TARGET_RUNS, level_points=LEVEL_POINTS)


@dataclass(frozen=True)
class Box:
    """The calibrated parameters' design box, natural units: ``low``, ``high``, ``centre`` (the
    recommendation), shape (d,) each; ``space`` maps them to and from the campaign's unit cube."""

    space: ParameterSpace
    centre: np.ndarray
    low: np.ndarray
    high: np.ndarray

    @classmethod
    def around(cls, space: ParameterSpace, centre: dict[str, float],
               plausible: dict[str, tuple[float, float]] | None = None) -> "Box":
        """The box around a recommendation (see the module docstring)."""
        c = space.to_unit(np.array([[centre[n] for n in space.names]]))[0]
        lo, hi = c - MIN_HALF_WIDTH, c + MIN_HALF_WIDTH
        for i, n in enumerate(space.names):
            if plausible and n in plausible:
                p = space.to_unit(np.array([[plausible[m][0] if m == n else centre[m] for m in space.names],
                                            [plausible[m][1] if m == n else centre[m] for m in space.names]]))
                lo[i], hi[i] = min(lo[i], p[0, i]), max(hi[i], p[1, i])
        lo, hi = np.clip(lo, 0.0, 1.0), np.clip(hi, 0.0, 1.0)
        nat = space.from_unit(np.vstack([lo, hi]))
        return cls(space, np.array([centre[n] for n in space.names], dtype=float), nat[0], nat[1])

    def reach(self, best: np.ndarray) -> "Box | None":
        """The box widened past each edge that a fit's best point (scaled [−1, 1], shape (d,))
        sits at, by the box's own width on that side, within the parameter's bounds; None where
        the best point is inside, or every edge it sits at is a bound already. An effect that adds
        strength is compensated by the calibrated parameters (a rough wall by a lower μs) by more
        than :data:`MIN_HALF_WIDTH` where it is strong: the fit then stops at the box's edge, and
        so does the recalibration."""
        c = self.space.to_unit(self.centre[None])[0]
        lo, hi = (self.space.to_unit(v[None])[0] for v in (self.low, self.high))
        new_lo, new_hi = lo.copy(), hi.copy()
        for i, b in enumerate(np.asarray(best, dtype=float)):
            if b <= -1.0 + EDGE and lo[i] > 0.0:
                new_lo[i] = max(0.0, lo[i] - (c[i] - lo[i]))
            if b >= 1.0 - EDGE and hi[i] < 1.0:
                new_hi[i] = min(1.0, hi[i] + (hi[i] - c[i]))
        if np.array_equal(new_lo, lo) and np.array_equal(new_hi, hi):
            return None
        nat = self.space.from_unit(np.vstack([new_lo, new_hi]))
        return Box(self.space, self.centre, nat[0], nat[1])

    def _cube(self, natural: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        u = self.space.to_unit(np.atleast_2d(natural))
        lo, hi = self.space.to_unit(self.low[None])[0], self.space.to_unit(self.high[None])[0]
        return u, (lo, hi)

    def scaled(self, natural: np.ndarray) -> np.ndarray:
        """Natural values, shape (n, d), to [−1, 1] over the box (log where the space is)."""
        u, (lo, hi) = self._cube(natural)
        return 2.0 * (u - lo) / np.where(hi > lo, hi - lo, 1.0) - 1.0

    def natural(self, scaled: np.ndarray) -> np.ndarray:
        """[−1, 1] over the box, shape (n, d), to natural values."""
        _, (lo, hi) = self._cube(self.centre)
        u = lo + (np.atleast_2d(scaled) + 1.0) / 2.0 * (hi - lo)
        return self.space.from_unit(u)


@dataclass(frozen=True)
class DesignPoint:
    """One design point: a label, the calibrated parameters and the effect parameters (natural
    units; effect parameters absent are off), the seeds it runs and the fidelity it runs at (""
    the campaign's cell, the target; a cheaper fidelity's preset name in a diagnosis across
    fidelities)."""

    label: str
    params: dict[str, float]
    effect: str | None
    effect_values: dict[str, float]
    seeds: tuple[int, ...]
    fidelity: str = ""


def _sobol(dim: int, n: int, seed: int) -> np.ndarray:
    """The first n points of a scrambled Sobol sequence, shape (n, dim) (n need not be a power of
    two: a design's budget rarely is, and SciPy's warning about it is noise here)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return qmc.Sobol(dim, scramble=True, seed=seed).random(n)


def design_points(box: Box, effects: list[Effect], budget: Budget, seed: int = 0, cheap: str = "") -> list[DesignPoint]:
    """The diagnosis's design (see the module docstring); every simulation has its own seed.

    With ``cheap`` (a cheaper fidelity's name: a diagnosis across fidelities) every point runs at
    it, and a first point, "calibrated", runs ``budget.target_replicates`` seeds at the target,
    where the gap is measured."""
    names = box.space.names
    centre = dict(zip(names, map(float, box.centre)))
    seeds = iter(range(SEED_BASE + 1000 * seed, SEED_BASE + 1000 * seed + 1000))
    points = []
    if cheap:
        first = SEED_BASE + 1000 * seed + TARGET_SEED_OFFSET
        points.append(DesignPoint("calibrated", centre, None, {}, tuple(range(first, first + budget.target_replicates))))
    points.append(DesignPoint(f"calibrated at {cheap}" if cheap else "calibrated", centre, None, {},
                              tuple(next(seeds) for _ in range(budget.replicates)), cheap))
    d = len(names)
    if budget.baseline:
        u = _sobol(d, budget.baseline, seed)
        for k, row in enumerate(box.natural(2.0 * u - 1.0)):
            points.append(DesignPoint(f"baseline {k + 1}", dict(zip(names, map(float, row))), None, {}, (next(seeds),),
                                      cheap))
    for j, effect in enumerate(effects):
        k_eff = len(effect.parameters)
        u = _sobol(d + k_eff, budget.per_effect, seed + 1 + j)
        cal = box.natural(2.0 * u[:, :d] - 1.0)
        for k in range(budget.per_effect):
            values = {p.name: float(p.off + u[k, d + i] * (p.high - p.off)) for i, p in enumerate(effect.parameters)}
            points.append(DesignPoint(f"{effect.name} {k + 1}", dict(zip(names, map(float, cal[k]))), effect.name,
                                      values, (next(seeds),), cheap))
    return points


def reach_points(old: Box, box: Box, effect: Effect, budget: Budget, seed: int = 0, cheap: str = "") -> list[DesignPoint]:
    """The points a box widened past ``old`` (:meth:`Box.reach`) adds: ``budget.baseline`` points
    without any effect and ``budget.per_effect`` of ``effect`` (the candidate whose fit reached the
    edge), their calibrated parameters drawn in the new part of the box (a Sobol design over the
    whole box, mapped into the slab beyond each moved edge), one seed each, at ``cheap``."""
    names = box.space.names
    d = len(names)
    lo_old, hi_old = box.scaled(old.low[None])[0], box.scaled(old.high[None])[0]   # the old box, scaled on the new
    seeds = iter(range(SEED_BASE + 1000 * seed + REACH_SEED_OFFSET, SEED_BASE + 1000 * seed + TARGET_SEED_OFFSET))

    def into_new_part(u: np.ndarray) -> np.ndarray:
        """Unit rows on the whole new box, the first moved dimension squeezed into its new slab."""
        x = 2.0 * u - 1.0
        moved = [i for i in range(d) if lo_old[i] > -1.0 + 1e-9 or hi_old[i] < 1.0 - 1e-9]
        i = moved[0]
        low_slab, high_slab = lo_old[i] + 1.0, 1.0 - hi_old[i]          # widths of the new parts
        t = u[:, i] * (low_slab + high_slab)
        x[:, i] = np.where(t < low_slab, -1.0 + t, hi_old[i] + (t - low_slab))
        return box.natural(x)

    points = []
    if budget.baseline:
        for k, row in enumerate(into_new_part(_sobol(d, budget.baseline, seed + 100))):
            points.append(DesignPoint(f"reach baseline {k + 1}", dict(zip(names, map(float, row))), None, {},
                                      (next(seeds),), cheap))
    k_eff = len(effect.parameters)
    u = _sobol(d + k_eff, budget.per_effect, seed + 101)
    cal = into_new_part(u[:, :d])
    for k in range(budget.per_effect):
        values = {p.name: float(p.off + u[k, d + i] * (p.high - p.off)) for i, p in enumerate(effect.parameters)}
        points.append(DesignPoint(f"reach {effect.name} {k + 1}", dict(zip(names, map(float, cal[k]))), effect.name,
                                  values, (next(seeds),), cheap))
    return points


def level_point(box: Box, effect: Effect, index: int, seed: int = 0) -> DesignPoint:
    """A candidate's point at the target fidelity (a diagnosis across fidelities): the calibrated
    parameters at the box's centre, the effect's parameters at :data:`LEVEL_FRACTION` of their
    range, one seed (``index``: the candidate's position in the list, which keeps each candidate's
    seed its own)."""
    names = box.space.names
    values = {p.name: float(p.off + LEVEL_FRACTION * (p.high - p.off)) for p in effect.parameters}
    seed_id = SEED_BASE + 1000 * seed + LEVEL_SEED_OFFSET + index
    return DesignPoint(f"{effect.name} at the target", dict(zip(names, map(float, box.centre))), effect.name, values,
                       (seed_id,))
