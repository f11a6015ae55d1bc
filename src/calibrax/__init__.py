"""calibrax: calibrate DEM powder-model parameters against a measured FT4 shear test with
Efficient Global Optimisation (Kriging + q-point Expected Improvement).

The public API, re-exported from its modules.
"""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("calibrax")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

from calibrax.core.acquisition import Acquisition, Observations
from calibrax.core.campaign import Campaign, CampaignSummary, run_campaign
from calibrax.core.config import CampaignConfig, load_config, parse_config
from calibrax.core.executor import Executor, LocalExecutor, SimulationTask
from calibrax.core.experiment import Experiment, load_experiment
from calibrax.core.metric import Metric, MetricValue
from calibrax.core.parameters import Parameter, ParameterSpace
from calibrax.core.sheartest import (FIDELITY_PRESETS, PROCEDURES, Geometry, Material, Numerics, Procedure,
                                     Provenance, ShearCellSpec, ShearTestResult, SizeDistribution, StepRecord,
                                     critical_time_step, find_peak, inertial_number, shear_stress_from_torque)
from calibrax.core.simulator import Simulator
from calibrax.core.store import CampaignStore
from calibrax.core.surrogate import Kriging
from calibrax.core.yieldlocus import MohrAnalysis, YieldLocus
from calibrax.errors import (CalibraxError, ConfigError, EngineNotFound, ExperimentError, PluginError,
                             SimulationFailed, SpecError, StoreError, StoreLockedError)
from calibrax.plugins.hookspecs import hookimpl
from calibrax.plugins.manager import get_manager

__all__ = [
    "__version__", "Acquisition", "Observations", "Campaign", "CampaignSummary", "run_campaign", "CampaignConfig",
    "load_config", "parse_config", "Executor", "LocalExecutor", "SimulationTask", "Experiment", "load_experiment",
    "Metric", "MetricValue", "Parameter", "ParameterSpace", "FIDELITY_PRESETS", "PROCEDURES", "Geometry",
    "Material", "Numerics", "Procedure", "Provenance", "ShearCellSpec", "ShearTestResult", "SizeDistribution",
    "StepRecord", "critical_time_step", "find_peak", "inertial_number", "shear_stress_from_torque", "Simulator",
    "CampaignStore", "Kriging", "MohrAnalysis", "YieldLocus", "CalibraxError", "ConfigError", "EngineNotFound",
    "ExperimentError", "PluginError", "SimulationFailed", "SpecError", "StoreError", "StoreLockedError",
    "hookimpl", "get_manager",
]
