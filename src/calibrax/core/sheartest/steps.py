"""One step of a shear test as recorded: its time series (:class:`StepRecord`), what a result
(:mod:`calibrax.core.sheartest.result`) is built from and the physics reads."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class StepRecord:
    """Time series of one preshear or shear step, each array shape (n,).

    Attributes:
        kind: "preshear" | "shear".
        target_stress: σ the servo holds, Pa.
        time: s since the start of the test. rotation: head rotation since the step's start, rad.
        shear_stress: τ from the head torque, Pa. normal_stress: σ measured on the head, Pa.
        bed_height: height of the head's lower face (blade tips excluded) above the base, m.
        base_spin: mean angular velocity about the cell's axis of the particles in the layer just
            above the base (just above the ribs' tops where the base has ribs: centres within one
            particle diameter of it), rad/s; compared with the head's rotation rate it says whether
            the bed slid on its base (:func:`~calibrax.core.sheartest.physics.base_slip`). Empty where a
            backend did not record it.
    """

    kind: str
    target_stress: float
    time: np.ndarray
    rotation: np.ndarray
    shear_stress: np.ndarray
    normal_stress: np.ndarray
    bed_height: np.ndarray
    base_spin: np.ndarray = field(default_factory=lambda: np.empty(0))

    CHANNELS = ("time", "rotation", "shear_stress", "normal_stress", "bed_height", "base_spin")
