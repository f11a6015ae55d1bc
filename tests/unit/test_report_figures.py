"""The report's figure helpers on hand-made data (issue 21): iso-line labels carry units and never
pile up, the cartography's frame is set by the points and not by one wide error bar, and the
identifiability statement says when the data leave the whole box within the noise."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from calibrax.report.figures import _frame, _place_labels, value_text  # noqa: E402


def test_values_are_written_in_their_display_unit():
    assert value_text("youngs_modulus", 2.81e10) == "E = 28.1 GPa"
    assert value_text("sliding_friction", 0.3) == "μs = 0.3"


def test_the_frame_holds_every_centre_whatever_the_error_bars():
    fig, ax = plt.subplots()
    centres = [(0.0, 4.8), (30.0, -0.7), (60.0, -8.0)]
    ax.errorbar([c[0] for c in centres], [c[1] for c in centres], yerr=[1.0, 40.0, 1.0], fmt="o")
    _frame(ax, centres)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x0 < 0.0 and x1 > 60.0 and y0 < -8.0 and y1 > 4.8  # every centre inside, with a margin ...
    assert y1 - y0 < 20.0  # ... and the ±40 kPa bar does not set the range
    plt.close(fig)


def test_labels_that_would_land_on_one_another_are_skipped():
    fig, ax = plt.subplots()
    ax.set_xlim(0, 100)
    ax.set_ylim(0, 10)
    labels = [(50.0, 5.0, "E = 5 GPa", "b", 0), (50.5, 5.05, "E = 8.9 GPa", "b", 0),  # on top of the first
              (20.0, 2.0, "μs = 0.3", "r", 1), (150.0, 5.0, "E = 50 GPa", "b", 0)]   # the last outside the frame
    _place_labels(ax, labels)
    written = [t.get_text() for t in ax.texts]
    assert written == ["E = 5 GPa", "μs = 0.3"], written
    plt.close(fig)


def _data(n_points: int):
    """CampaignData with ``n_points`` finished points over (E, μs) on the tiny cell (hand-made)."""
    from types import SimpleNamespace

    from calibrax.core.search.parameters import Parameter, ParameterSpace
    from calibrax.report.data import CampaignData, PointView

    space = ParameterSpace((Parameter("youngs_modulus", 5e9, 5e10, log=True), Parameter("sliding_friction", 0.1, 0.9)))
    points = [PointView(SimpleNamespace(metric=SimpleNamespace(value=1.0)), []) for _ in range(n_points)]
    return CampaignData(None, {"cell": {"name": "tiny"}}, space, None, points, {})


def _answer(ranges: dict, share: float):
    from calibrax.core.search.answer import Answer

    names = ("youngs_modulus", "sliding_friction")
    return Answer(params={"youngs_modulus": 2e10, "sliding_friction": 0.35}, predicted=1.2, predicted_sd=0.4,
                  threshold=7.5, rate=0.95, ranges=ranges,
                  constrained={n: bool(ranges) and n == "sliding_friction" for n in names}, region_share=share,
                  n_points=6, bounds={"youngs_modulus": (5e9, 5e10), "sliding_friction": (0.1, 0.9)})


def test_the_statement_says_when_the_data_do_not_constrain_the_parameters():
    from calibrax.report.figures import _identifiability

    wide = {"youngs_modulus": (5e9, 5e10), "sliding_friction": (0.3, 0.4)}
    everywhere = _identifiability(_data(6), _answer(wide, 1.0))
    assert "100 % of the box" in everywhere and "do not constrain the parameters" in everywhere
    assert "E anywhere in 5 GPa to 50 GPa: the test does not constrain it" in everywhere
    assert "μs = 0.35 (plausible 0.3 to 0.4)" in everywhere
    assert "6 points (6 simulations) on the 'tiny' cell" in everywhere and "seeds_per_point" in everywhere
    nowhere = _identifiability(_data(6), _answer({}, 0.0))
    assert "With 6 finished points the surrogate is rough" in nowhere and "about 20 for 2 parameters" in nowhere
    assert "cannot reach" in _identifiability(_data(30), _answer({}, 0.0))
    from dataclasses import replace

    shelf = {"youngs_modulus": (5e9, 5e10), "sliding_friction": (0.2, 0.9)}
    one_sided = replace(_answer(shelf, 0.87), constrained={"youngs_modulus": False, "sliding_friction": False},
                        ruled_out={"youngs_modulus": (False, False), "sliding_friction": (True, False)})
    text = _identifiability(_data(6), one_sided)
    assert "μs ≥ 0.2 (plausible 0.2 to 0.9): the test rules out lower values, not higher ones" in text
    assert "bound the parameters from one side at most" in text and "do not constrain the parameters" not in text
