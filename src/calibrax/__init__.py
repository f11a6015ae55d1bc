"""calibrax: calibrate DEM powder-model parameters against a measured FT4 shear test with
Efficient Global Optimisation (Kriging + q-point Expected Improvement).

The public API, re-exported from its modules. Names are imported on first use, so that a
simulation process (which needs the spec and a backend) never pays for torch and BoTorch.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version as _version
from typing import Any

try:
    __version__ = _version("calibrax")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

_EXPORTS = {
    "calibrax.core.search.acquisition": ["Acquisition", "Observations"],
    "calibrax.core.studies.campaign": ["Campaign", "CampaignSummary", "run_campaign"],
    "calibrax.core.config": ["CampaignConfig", "load_config", "parse_config"],
    "calibrax.core.running.executor": ["Executor", "LocalExecutor", "SimulationTask"],
    "calibrax.core.data.experiment": ["Experiment", "load_experiment"],
    "calibrax.core.search.metric": ["Metric", "MetricValue"],
    "calibrax.core.search.parameters": ["Parameter", "ParameterSpace"],
    "calibrax.core.sheartest": ["FIDELITY_PRESETS", "PROCEDURES", "Geometry", "Material", "Numerics", "Procedure",
                                "Provenance", "ShearCellSpec", "ShearTestResult", "SizeDistribution", "StepRecord",
                                "critical_time_step", "find_peak", "inertial_number", "shear_stress_from_torque"],
    "calibrax.core.simulator": ["Simulator"],
    "calibrax.core.running.store": ["CampaignStore"],
    "calibrax.core.search.surrogate": ["Kriging"],
    "calibrax.core.sheartest.yieldlocus": ["MohrAnalysis", "YieldLocus"],
    "calibrax.errors": ["CalibraxError", "ConfigError", "EngineNotFound", "ExperimentError", "PluginError",
                        "SimulationFailed", "SpecError", "StoreError", "StoreLockedError"],
    "calibrax.core.hookspecs": ["hookimpl"],
    "calibrax.core.registry": ["get_manager"],
    "calibrax.report": ["build_report", "build_single_file_report"],
    "calibrax.report.trials": ["trial_rows", "write_trials_csv"],
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}
__all__ = ["__version__", *_WHERE]


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module 'calibrax' has no attribute {name!r}")
    value = getattr(importlib.import_module(_WHERE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
