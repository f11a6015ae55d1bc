"""What one simulation of a campaign is: its seed, its work folder, its spec."""

from __future__ import annotations

from pathlib import Path

from calibrax.core.data.pseudo import EXPERIMENT_SEED_BASE
from calibrax.core.search.parameters import spec_values
from calibrax.core.sheartest.spec import ShearCellSpec

def simulation_seed(campaign_seed: int, point_id: int, index: int) -> int:
    """The seed of simulation ``index`` of point ``point_id``: distinct, reproducible, and below
    :data:`EXPERIMENT_SEED_BASE`, so never the seed of a pseudo-experiment's replicate."""
    return (campaign_seed * 1_000_003 + point_id * 1_000 + index) % EXPERIMENT_SEED_BASE


def simulation_workdir(workdir: Path, point_id: int, index: int) -> Path:
    """The work folder of simulation ``index`` of point ``point_id`` under the campaign's ``workdir``."""
    return Path(workdir) / f"p{point_id:06d}-s{index}"


def point_spec(base: ShearCellSpec, params: dict[str, float], seed: int) -> ShearCellSpec:
    """The spec of one simulation: the calibrated values ({parameter name: natural value}, each
    set at its spec path: :func:`~calibrax.core.search.parameters.spec_path`) and the seed set on
    the base spec."""
    return base.with_values(spec_values(params)).replace(numerics={"seed": int(seed)})
