"""The ``numba_dem`` Simulator: calibrax's in-house Numba DEM backend."""

from __future__ import annotations

import time
from pathlib import Path

from calibrax.core.sheartest import Provenance, ShearCellSpec, ShearTestResult
from calibrax.errors import SimulationFailed, SpecError

from . import __version__

# Numba and the engine are imported by the methods that use them: every simulation process loads
# every registered plugin, and one that runs another backend need not pay for Numba's import

LOG_NAME = "numba_dem.log"


class NumbaDEMSimulator:
    """Hertz–Mindlin DEM of the FT4 shear test in Numba (see the package README).

    ``simulate`` is deterministic for a given spec and thread count (``spec.numerics.threads``,
    capped at the cores Numba sees) and writes only ``workdir/numba_dem.log``.
    """

    name = "numba_dem"

    def capabilities(self) -> frozenset[str]:
        """Optional effects modelled: wall friction, size distributions, SJKR cohesion, base
        ribs, rolling friction, the compressibility ramp, a periodic sector of the cell, shear
        steps branched from one preshear, and stepping on a CUDA GPU (``numerics.device: cuda``,
        :mod:`calibrax_numba_dem.cuda_engine`)."""
        return frozenset({"wall_friction", "size_distribution", "cohesion", "base_ribs", "rolling_friction",
                          "compressibility_test", "sector", "branched_steps", "cuda"})

    def check_machine(self, spec: ShearCellSpec) -> None:
        """Raise SpecError naming ``numerics.device`` when ``spec`` asks for a CUDA GPU and none is
        visible on this machine (campaigns call it before anything runs, where simulations run
        locally)."""
        if spec.numerics.device == "cuda":
            from .cuda_engine import cuda_available

            if not cuda_available():
                raise SpecError("numerics.device", "cuda needs a CUDA GPU, and none is visible on this machine "
                                "(numba.cuda.is_available() is False): set cell.numerics.device: cpu, or run "
                                "where a GPU is (a Dask executor's workers with gpus: 1)")

    def version(self) -> str:
        """``numba_dem <version> (numba <version>)``."""
        import numba

        return f"numba_dem {__version__} (numba {numba.__version__})"

    def simulate(self, spec: ShearCellSpec, workdir: Path) -> ShearTestResult:
        """Run the whole test and return its result; raise SpecError before any work on a bad
        spec, SimulationFailed (with the log tail) on NaN, escape or blow-up."""
        import numba

        from calibrax.core.sheartest.stage_records import summarise

        from .procedure import RunLog, ShearTestDriver, new_logger

        spec.validate()
        self.check_machine(spec)
        threads = spec.numerics.threads
        if threads > numba.config.NUMBA_NUM_THREADS:
            raise SpecError("numerics.threads", f"numba_dem can use at most {numba.config.NUMBA_NUM_THREADS} "
                            f"threads here (NUMBA_NUM_THREADS), got {threads}")
        workdir = Path(workdir)
        workdir.mkdir(parents=True, exist_ok=True)
        logger = new_logger(workdir / LOG_NAME)
        log = RunLog(logger)
        t0 = time.perf_counter()
        old_threads = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            log(f"{self.version()}; spec {spec.name} hash {spec.spec_hash()}; {spec.particle_count} particles, "
                f"dt {spec.time_step:.3e} s, {threads} thread(s)")
            driver = ShearTestDriver(spec, log)
            try:
                summary = summarise(driver.run())
            except SimulationFailed:
                raise
            except Exception as exc:  # an engine bug must still come back as a failed run
                log(f"error: {exc!r}")
                raise SimulationFailed(f"numba_dem crashed: {exc!r}", log.tail(), kind="crash") from exc
            wall = time.perf_counter() - t0
            log(f"done in {wall:.1f} s wall time, {driver.sys.list_builds} neighbour-list builds; CPU by stage: "
                f"{driver.stage_cpu_words()}")
        finally:
            numba.set_num_threads(old_threads)
            for h in list(logger.handlers):
                h.close()
                logger.removeHandler(h)
        prov = Provenance(backend=self.name, engine_version=self.version(), spec_hash=spec.spec_hash(),
                          seed=spec.numerics.seed, wall_time=wall, particle_count=driver.sys.n, threads=threads,
                          extra={"time_step": spec.time_step, "simulated_time": driver.time,
                                 "servo_sigma_errors": summary.sigma_errors,
                                 "consolidation_time": summary.consolidation_time,
                                 "consolidation_rotation": summary.consolidation_rotation,
                                 "insertion_gap_radii": summary.insertion_gap,
                                 "stage_cpu": {k: round(v, 3) for k, v in driver.stage_cpu.items()},
                                 "stress_area": "pi*head_radius**2"})
        return ShearTestResult.from_steps(spec, summary.steps, summary.bulk_density, prov, driver.warnings,
                                          conditioned_bulk_density=summary.conditioned_bulk_density,
                                          compression_height=summary.compression_height)
