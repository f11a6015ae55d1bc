"""The campaign's answer: the model's recommendation and the region of plausible parameters.

On noisy DEM the best *observed* distance is a lucky seed (docs/explanation/answer.md). The answer
reads the Kriging model instead:

* the **recommendation** is the minimiser of the posterior mean of the (transformed) distance over
  the box (for :class:`~calibrax.core.search.composite.CompositeKriging`, the expected distance of the
  features' joint prediction): where the model expects a new simulation to land closest to the
  experiment;
* the **plausible region** is where the model cannot rule out that a simulation lands within the
  metric's noise threshold T (the distance the true parameters stay below 95 % of the time): the
  points x with m(x) − 2 s(x) ≤ t(T), m and s the posterior mean and s.d. of the transformed
  distance's mean and t the transform. Unsampled corners stay plausible until the model has seen
  them, as history matching's not-ruled-out-yet region does;
* a parameter is **constrained** when the region's projection on it covers less than
  :data:`UNCONSTRAINED_SHARE` of its searched range (unit-cube, i.e. log, scale where the parameter
  is log-scaled). The projection may fall apart into pieces (a plausible core and an unsampled end
  the model cannot rule out yet): it covers the sum of the pieces, not the hull from the first to
  the last, and the statement names each piece; otherwise the answer says the test does not constrain it, and, where the region
  stops at least :data:`ONE_SIDED_SHARE` short of one end of the range, which side the test rules
  out ("μs ≥ 0.2: the test rules out lower values, not higher ones"): a coarse cell whose features
  saturate bounds a parameter from one side only (docs/explanation/answer.md).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from calibrax.core.search.parameters import DISPLAY, ParameterSpace

#: a parameter whose plausible values span at least this share of its searched range (unit cube) is
#: reported as not constrained by the test
UNCONSTRAINED_SHARE = 0.8
#: an unconstrained parameter's plausible values that stop at least this share of its searched range
#: (unit cube) short of one end are reported as bounded on that side
ONE_SIDED_SHARE = 0.1
#: the region's lower bound: posterior mean minus this many posterior s.d.
REGION_SIGMAS = 2.0
#: scrambled Sobol points over the box on which the region and the recommendation are evaluated
GRID_POINTS = 4096
#: the projection's pieces are read on this many bins of each parameter's searched range (unit
#: cube); a run of more than PIECE_GAP_BINS empty bins between plausible ones splits a piece (fewer
#: are the Sobol grid's own holes: 4 096 points leave about 80 to a bin of a 2-D box)
PIECE_BINS = 50
PIECE_GAP_BINS = 2



def _show(name: str, value: float) -> str:
    _, factor, unit = DISPLAY.get(name, (name, 1.0, ""))
    return f"{value * factor:.3g}" + (f" {unit}" if unit else "")


def _symbol(name: str) -> str:
    return DISPLAY.get(name, (name,))[0]


@dataclass(frozen=True)
class Answer:
    """What the campaign says about the parameters (natural units throughout).

    Attributes:
        params: the recommendation, {name: value}.
        predicted: the model's distance at the recommendation (back-transformed posterior mean).
        predicted_sd: its s.d. (the model's, not one seed's).
        threshold, rate: the metric's noise threshold and the rate the truth meets it at (NaN: none).
        ranges: {name: (low, high)} of the plausible region's projection; empty when no point of
            the box is plausible.
        constrained: {name: whether the test constrains it} (False for every name when empty).
        ruled_out: {name: (below, above)}: whether the region stops at least :data:`ONE_SIDED_SHARE`
            of the range short of its low and its high end (unit cube); empty: neither (stores
            written before it).
        region_share: share of the box that is plausible, in [0, 1].
        n_points: finished points the model was fitted on.
        spans: {name: the region's projection as a share of the searched range, unit cube (log
            scale for a log-scaled parameter)}, in [0, 1]; empty for stores written before it.
        log_scaled: names of the log-scaled parameters (their width is stated as a factor).
        pieces: {name: the disjoint intervals, low to high, of the region's projection} (natural
            units); a parameter with one piece, or a store written before them, has none here and
            its interval is ``ranges``'.
    """

    params: dict[str, float]
    predicted: float
    predicted_sd: float
    threshold: float
    rate: float
    ranges: dict[str, tuple[float, float]]
    constrained: dict[str, bool]
    region_share: float
    n_points: int
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    ruled_out: dict[str, tuple[bool, bool]] = field(default_factory=dict)
    spans: dict[str, float] = field(default_factory=dict)
    log_scaled: tuple[str, ...] = ()
    pieces: dict[str, tuple[tuple[float, float], ...]] = field(default_factory=dict)

    def statement(self) -> str:
        """"μs = 0.33 (plausible 0.29–0.38); E anywhere in 5–50 GPa: the test does not constrain it."."""
        if not math.isfinite(self.threshold):
            return ("This metric states no noise threshold, so there is no plausible region to tell which "
                    "parameters the test constrains.")
        if not self.ranges:
            return (f"No parameter set in the box is plausible: the model rules out every point reaching the noise "
                    f"threshold d = {self.threshold:.3g} (lowest predicted d = {self.predicted:.3g} at the "
                    "recommendation). The model cannot reach the experiment here: widen the bounds, or look for "
                    "the missing effect (calibrax diagnose: docs/tutorials/diagnose-the-gap.md).")
        parts = []
        for name, value in self.params.items():
            lo, hi = self.ranges[name]
            if self.constrained[name] and len(self.pieces.get(name, ())) > 1:
                within = " or ".join(f"{_show(name, a)} to {_show(name, b)}" for a, b in self.pieces[name])
                parts.append(f"{_symbol(name)} = {_show(name, value)} (plausible {within}: "
                             f"{100 * self.spans[name]:.0f} % of the searched range)")
            elif self.constrained[name]:
                parts.append(f"{_symbol(name)} = {_show(name, value)} (plausible {_show(name, lo)} to "
                             f"{_show(name, hi)}{self._width(name, lo, hi)})")
            else:
                parts.append(self._unconstrained(name, lo, hi))
        return "; ".join(parts) + "."

    def _width(self, name: str, lo: float, hi: float) -> str:
        """", width 0.21: 26 % of the searched range" (a factor, "×1.9", for a log-scaled parameter);
        empty where the store predates ``spans``."""
        if name not in self.spans:
            return ""
        width = f"×{hi / lo:.2g}" if name in self.log_scaled and lo > 0 else _show(name, hi - lo)
        return f", width {width}: {100 * self.spans[name]:.0f} % of the searched range"

    def _unconstrained(self, name: str, lo: float, hi: float) -> str:
        """What the answer says of a parameter the test does not constrain: the side it rules out,
        if one, else the searched range."""
        below, above = self.ruled_out.get(name, (False, False))
        sym, low, high = _symbol(name), _show(name, lo), _show(name, hi)
        if below and not above:
            return (f"{sym} ≥ {low} (plausible {low} to {high}): the test rules out lower values, not "
                    "higher ones")
        if above and not below:
            return (f"{sym} ≤ {high} (plausible {low} to {high}): the test rules out higher values, not "
                    "lower ones")
        blo, bhi = self.bounds.get(name, (lo, hi))
        return f"{sym} anywhere in {_show(name, blo)} to {_show(name, bhi)}: the test does not constrain it"

    def summary(self) -> str:
        """The statement plus the recommendation's predicted distance and the region's size."""
        rec = ", ".join(f"{_symbol(k)} = {_show(k, v)}" for k, v in self.params.items())
        noise = (f"noise threshold {self.threshold:.3g}, met by the truth {self.rate:.0%} of the time"
                 if math.isfinite(self.threshold) else "no noise threshold stated")
        return (f"{self.statement()} Recommended: {rec}, predicted d = {self.predicted:.3g} ± {self.predicted_sd:.2g} "
                f"({noise}); plausible region {100 * self.region_share:.0f} % of the box, from {self.n_points} "
                "points.")

    def identified(self) -> list[str]:
        """Names of the parameters the answer reports as constrained."""
        return [k for k, v in self.constrained.items() if v]

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["ranges"] = {k: list(v) for k, v in self.ranges.items()}
        d["bounds"] = {k: list(v) for k, v in self.bounds.items()}
        d["ruled_out"] = {k: list(v) for k, v in self.ruled_out.items()}
        d["log_scaled"] = list(self.log_scaled)
        d["pieces"] = {k: [list(p) for p in v] for k, v in self.pieces.items()}
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Answer":
        return cls(params={k: float(v) for k, v in d["params"].items()}, predicted=float(d["predicted"]),
                   predicted_sd=float(d["predicted_sd"]), threshold=float(d["threshold"]), rate=float(d["rate"]),
                   ranges={k: (float(v[0]), float(v[1])) for k, v in d["ranges"].items()},
                   constrained={k: bool(v) for k, v in d["constrained"].items()},
                   region_share=float(d["region_share"]), n_points=int(d["n_points"]),
                   bounds={k: (float(v[0]), float(v[1])) for k, v in d.get("bounds", {}).items()},
                   ruled_out={k: (bool(v[0]), bool(v[1])) for k, v in d.get("ruled_out", {}).items()},
                   spans={k: float(v) for k, v in d.get("spans", {}).items()},
                   log_scaled=tuple(d.get("log_scaled", ())),
                   pieces={k: tuple((float(a), float(b)) for a, b in v) for k, v in d.get("pieces", {}).items()})


def projection_pieces(values: np.ndarray) -> list[tuple[float, float]]:
    """The disjoint intervals that unit-cube coordinates ``values`` (shape (n,), n ≥ 1) fall in,
    low to high: :data:`PIECE_BINS` bins, runs of plausible bins joined across gaps of at most
    :data:`PIECE_GAP_BINS` empty ones; each interval from its lowest value to its highest."""
    bins = np.clip((values * PIECE_BINS).astype(int), 0, PIECE_BINS - 1)
    occupied = np.unique(bins)
    runs, start = [], occupied[0]
    for prev, b in zip(occupied[:-1], occupied[1:]):
        if b - prev - 1 > PIECE_GAP_BINS:
            runs.append((start, prev))
            start = b
    runs.append((start, occupied[-1]))
    out = []
    for a, b in runs:
        inside = values[(bins >= a) & (bins <= b)]
        out.append((float(inside.min()), float(inside.max())))
    return out


def grid(dim: int, n: int = GRID_POINTS, seed: int = 0) -> np.ndarray:
    """``n`` scrambled Sobol points in [0, 1]^dim plus the box's corners, shape (n + 2^dim, dim)."""
    from calibrax.core.search.design import sobol_points

    corners = np.array(np.meshgrid(*[[0.0, 1.0]] * dim)).reshape(dim, -1).T
    return np.vstack([sobol_points(dim, n, seed=seed), corners])


def recommend_unit(model, dim: int, candidates: np.ndarray | None = None) -> np.ndarray:
    """The unit-cube minimiser of the model's posterior mean, shape (dim,): best of ``candidates``
    (default :func:`grid`, plus the evaluated points), then refined twice on a Sobol cloud in a box
    a tenth, then a hundredth, as wide around it (clipped to the cube)."""
    cand = grid(dim) if candidates is None else candidates
    cand = np.vstack([cand, model.train_x.numpy()])
    mean, _ = model.latent(cand)
    best, best_mean = cand[int(np.argmin(mean))], float(mean.min())
    local = grid(dim, 512, seed=1)[:512] - 0.5
    for width in (0.1, 0.01):
        around = np.clip(best + width * local, 0.0, 1.0)
        m, _ = model.latent(around)
        if float(m.min()) < best_mean:
            best, best_mean = around[int(np.argmin(m))], float(m.min())
    return best


def answer_from_model(model, space: ParameterSpace, threshold: float, rate: float, n_points: int,
                      candidates: np.ndarray | None = None) -> Answer:
    """The :class:`Answer` of a fitted :class:`~calibrax.core.search.surrogate.Kriging` model of the distance."""
    dim = space.dim
    cand = grid(dim) if candidates is None else candidates
    best_u = recommend_unit(model, dim, cand)
    pred, pred_sd = model.predict(best_u.reshape(1, -1))
    mean, sd = model.latent(cand)
    if math.isfinite(threshold):
        inside = mean - REGION_SIGMAS * sd <= model.to_model_units(threshold)
    else:
        inside = np.zeros(len(cand), dtype=bool)
    names = space.names
    params = space.as_dict(space.from_unit(best_u.reshape(1, -1))[0])
    bounds = {p.name: (float(p.low), float(p.high)) for p in space.parameters}
    ranges, constrained, ruled_out, spans, pieces = {}, {}, {}, {}, {}
    if inside.any():
        sub = cand[inside]
        nat = space.from_unit(sub)
        for j, name in enumerate(names):
            ranges[name] = (float(nat[:, j].min()), float(nat[:, j].max()))
            low_u, high_u = float(sub[:, j].min()), float(sub[:, j].max())
            parts = projection_pieces(sub[:, j])
            # a piece of one grid point (a corner) counts as one bin
            spans[name] = min(1.0, sum(max(b - a, 1.0 / PIECE_BINS) for a, b in parts)) if len(parts) > 1 \
                else high_u - low_u
            if len(parts) > 1:
                pieces[name] = tuple(tuple(float(v) for v in space.parameters[j].from_unit(np.array(piece))) for piece in parts)
            constrained[name] = spans[name] < UNCONSTRAINED_SHARE
            ruled_out[name] = (low_u >= ONE_SIDED_SHARE, high_u <= 1.0 - ONE_SIDED_SHARE)
    else:
        constrained = {name: False for name in names}
    return Answer(params=params, predicted=float(pred[0]), predicted_sd=float(pred_sd[0]), threshold=float(threshold),
                  rate=float(rate), ranges=ranges, constrained=constrained, region_share=float(inside.mean()),
                  n_points=int(n_points), bounds=bounds, ruled_out=ruled_out, spans=spans,
                  log_scaled=tuple(p.name for p in space.parameters if p.log), pieces=pieces)
