"""The campaign's points as the search sees them: observations for the Kriging model (a point that
failed physically enters with a penalty distance), the model fits (the composite model by default,
the distance model as its fallback), the answer read off the model against the metric's noise
threshold, the screen that keeps a crash from being proposed again, and the rule that says when
the answer has settled (``budget.patience``).
"""

from __future__ import annotations

import math

import numpy as np

from calibrax.core.search.acquisition import Observations
from calibrax.core.search.answer import Answer, answer_from_model
from calibrax.core.search.models import TrainingData, fit_surrogate
from calibrax.core.search.records import PointRecord, Status
from calibrax.errors import FailureKind

#: unit-cube distance (max norm) under which a proposal repeats a point
DUPLICATE_TOL = 1e-3


def physically_failed(point: PointRecord) -> bool:
    """Every simulation of the point finished, none gave a metric, and at least one failure was
    about the parameters (not a lost worker or a cancellation)."""
    infrastructure = (FailureKind.WORKER_LOST, FailureKind.CANCELLED)
    return point.status == Status.FAILED and any(s.status == Status.FAILED and s.kind not in infrastructure for s in point.sims)


def observations(points: list[PointRecord], penalise_failures: bool = True,
                 levels: dict[str, float] | None = None) -> Observations:
    """Unit-cube points and distances of every point with a metric, plus (with a penalty distance)
    every point that failed physically; with ``levels`` ({fidelity name: level}, a multi-fidelity
    campaign's), each point's fidelity level too."""
    d = len(points[0].names) if points else 0
    done = [p for p in points if p.metric is not None and math.isfinite(p.metric.value)]
    x = [p.unit for p in done]
    y = [p.metric.value for p in done]
    y_std = [p.metric.uncertainty for p in done]
    failed = [p for p in points if physically_failed(p)] if penalise_failures else []
    if failed and y:
        penalty = max(y) + 0.1 * (max(y) - min(y) or abs(max(y)) or 1.0)
        x += [p.unit for p in failed]
        y += [penalty] * len(failed)
        y_std += [float("nan")] * len(failed)
    else:
        failed = []
    level = None if levels is None else np.asarray([levels[p.fidelity] for p in done + failed], float)
    if not x:
        return Observations(np.zeros((0, d)), np.zeros(0), np.zeros(0), None if levels is None else np.zeros(0))
    return Observations(np.stack(x), np.asarray(y, float), np.asarray(y_std, float), level)


#: the answer has settled when, between successive batches, the recommendation moves less than this
#: (unit cube, max norm) and the plausible region's share of the box changes by less than SETTLED_SHARE
SETTLED_MOVE = 0.02
SETTLED_SHARE = 0.02


def settled(answers: list[Answer], space, patience: int) -> bool:
    """Whether the last ``patience`` changes between successive answers were all below the
    settling limits (False when ``patience`` is 0 or there are too few answers): the stopping rule
    of ``budget.patience``. More simulations would move neither the recommendation nor the region."""
    if patience <= 0 or len(answers) < patience + 1:
        return False
    for a, b in zip(answers[-patience - 1:-1], answers[-patience:]):
        ua = space.to_unit(np.asarray([list(a.params.values())]))[0]
        ub = space.to_unit(np.asarray([list(b.params.values())]))[0]
        if np.max(np.abs(ua - ub)) >= SETTLED_MOVE or abs(a.region_share - b.region_share) >= SETTLED_SHARE:
            return False
    return True


def screen_repeats(unit: np.ndarray, points: list[PointRecord],
                   spare: np.ndarray) -> tuple[np.ndarray, list[tuple[str, str]]]:
    """Proposals ``unit`` shape (q, d) screened against the campaign's ``points``: one within
    :data:`DUPLICATE_TOL` (max norm, unit cube) of a point that failed physically is replaced by
    the first of the ``spare`` points (shape (m, d)) at least 0.05 from every point and proposal,
    so a crash is never proposed again; one that repeats a finished, pending or just-proposed point
    is kept: a noise-aware model asks for another seed there, and it runs as a replicate (a new
    point at the same parameters, its own seed). Returns the rows (q, d) and, per repeat,
    ("replicate" or "replaced", what it repeated)."""
    crashed = [physically_failed(p) for p in points]
    failed = [p.unit for p, c in zip(points, crashed) if c]
    others = [(p.unit, f"point {p.id}") for p, c in zip(points, crashed) if not c]
    out, notes = [], []
    for row in np.atleast_2d(unit):
        near = lambda ref: np.max(np.abs(ref - row)) < DUPLICATE_TOL  # noqa: E731
        crash = next((u for u in failed if near(u)), None)
        if crash is not None:
            notes.append(("replaced", "proposal repeats a point that failed"))
            taken = np.stack([p.unit for p in points] + out)
            row = next((c for c in spare if np.min(np.max(np.abs(taken - c), axis=1)) >= 0.05), row)
        else:
            twin = next((name for u, name in others if near(u)), None)
            if twin is None and any(near(u) for u in out):
                twin = "another proposal of this batch"
            if twin is not None:
                notes.append(("replicate", f"proposal repeats {twin}"))
        out.append(np.asarray(row, dtype=float))
    return np.stack(out), notes


def noise_threshold(finished: list[PointRecord]) -> tuple[float, float]:
    """The metric's noise threshold and rate over the finished points (their median: the threshold
    depends only on the experiment and the seeds per point, so they agree)."""
    values = [p.metric.threshold for p in finished if math.isfinite(p.metric.threshold)]
    rates = [p.metric.threshold_rate for p in finished if math.isfinite(p.metric.threshold_rate)]
    return (float(np.median(values)) if values else math.nan, float(np.median(rates)) if rates else math.nan)


def fit_distance_model(points: list[PointRecord], surrogate: dict[str, str], seed: int,
                       obs: Observations | None = None, levels: dict[str, float] | None = None):
    """A :class:`~calibrax.core.search.surrogate.Kriging` model of the points' distances (penalised
    failures included) with the options ``surrogate`` ({model, transform, noise}); None with < 2
    points. ``model: composite`` (the default) fits a composite model instead
    (:func:`~calibrax.core.search.models.fit_surrogate` picks the model).
    ``noise: metric`` takes the noise prior from the metric's threshold
    (:func:`~calibrax.core.search.surrogate.noise_sd_from_threshold`); ``fitted`` leaves it free. ``obs``:
    the points' :func:`observations`, when the caller has them already. With ``levels`` ({fidelity
    name: level}), a multi-fidelity campaign's
    :class:`~calibrax.core.search.multifidelity.MultiFidelityKriging`, read at the target."""
    obs = observations(points, levels=levels) if obs is None else obs
    if len(obs.y) < 2:
        return None
    finished = [p for p in points if p.metric is not None and math.isfinite(p.metric.value)]
    failed = [p for p in points if physically_failed(p)]
    threshold, _ = noise_threshold(finished)
    return fit_surrogate(TrainingData(obs, finished, failed, levels, threshold), surrogate, seed)


def campaign_answer(points: list[PointRecord], space, surrogate: dict[str, str], seed: int,
                    levels: dict[str, float] | None = None, model=None) -> Answer | None:
    """The campaign's :class:`Answer` from ``points`` in the parameter ``space``: ``model``
    (default: fitted on the points with the campaign's ``surrogate`` options, ``seed`` and fidelity
    ``levels``, the campaign's :attr:`~calibrax.core.fidelities.FidelityPlan.levels`) read against
    the metric's noise threshold; None with fewer than 3 finished points."""
    finished = [p for p in points if p.metric is not None and math.isfinite(p.metric.value)]
    if len(finished) < 3:
        return None
    model = model if model is not None else fit_distance_model(points, surrogate, seed, levels=levels)
    threshold, rate = noise_threshold(finished)
    return answer_from_model(model, space, threshold, rate, len(finished))


__all__ = ["DUPLICATE_TOL", "SETTLED_MOVE", "SETTLED_SHARE", "physically_failed", "observations", "settled",
           "screen_repeats", "noise_threshold", "fit_distance_model", "campaign_answer"]
