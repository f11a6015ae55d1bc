"""The ``liggghts`` Simulator: writes a LIGGGHTS input script and STL meshes from a
:class:`ShearCellSpec`, runs the Debian ``liggghts`` binary and parses its output."""

from __future__ import annotations

import math
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from calibrax.core.sheartest import (CONSOLIDATION_LIMIT_FACTOR, Provenance, ShearCellSpec, ShearTestResult,
                                     StepRecord, conditioned_bulk_density, insertion_time_limit,
                                     shear_stress_from_torque)
from calibrax.core.simulator import check_capabilities
from calibrax.errors import EngineNotFound, SimulationFailed

from . import __version__
from .script import APPROACH_SPEED, POURED_DUMP, SCRIPT_NAME, ScriptPlan, write_inputs

__all__ = ["LiggghtsSimulator", "find_liggghts", "run_liggghts", "INSTALL_HINT"]

INSTALL_HINT = "install it with `sudo apt-get install -y liggghts` (Debian/Ubuntu package liggghts 3.8)"
LOG_NAME = "log.liggghts"
SCREEN_NAME = "screen.liggghts"
_VERSION_RE = re.compile(r"LIGGGHTS \(Version (LIGGGHTS-[A-Za-z]+ [0-9][0-9.]*)")


def find_liggghts() -> str:
    """Path of the ``liggghts`` binary on PATH; :class:`EngineNotFound` with the install hint."""
    exe = shutil.which("liggghts")
    if exe is None:
        raise EngineNotFound(f"the LIGGGHTS binary `liggghts` is not on PATH; {INSTALL_HINT}")
    return exe


def _tail(path: Path, n: int = 40) -> str:
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return ""
    keep = [ln for ln in lines if ln.strip() and "whitelist" not in ln and "LIGGGHTS(R)" not in ln
            and "optimized" not in ln and "contact_models.h" not in ln]
    return "\n".join(keep[-n:])


def _kill_group(proc: subprocess.Popen) -> None:
    """End the process group of ``proc`` (started with its own session) and reap it."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        proc.kill()
    proc.wait()


def run_liggghts(workdir: Path, script: str = SCRIPT_NAME, threads: int = 1, timeout_s: float | None = None,
                 log_name: str = LOG_NAME, screen_name: str = SCREEN_NAME) -> Path:
    """Run ``liggghts -in script`` in ``workdir`` (under ``mpirun -np threads`` when threads > 1 and
    mpirun exists), stdout and stderr to ``screen_name``; returns the screen file's path.

    Raises:
        EngineNotFound: no ``liggghts`` on PATH.
        SimulationFailed: non-zero exit (kind "unstable" for lost atoms, else "crash") or timeout
            (kind "timeout"), with the tail of the engine's output.
    """
    exe = find_liggghts()
    workdir = Path(workdir)
    args = [exe, "-in", script, "-log", log_name, "-echo", "none", "-nocite"]
    if threads > 1:
        mpirun = shutil.which("mpirun")
        if mpirun is not None:
            args = [mpirun, "-np", str(int(threads))] + args
    stdbuf = shutil.which("stdbuf")
    if stdbuf is not None:  # line-buffered, so an MPI_Abort does not swallow the error message
        args = [stdbuf, "-oL", "-eL"] + args
    screen = workdir / screen_name
    env = dict(os.environ)
    env.setdefault("OMPI_MCA_btl_vader_single_copy_mechanism", "none")
    if threads > 1 and hasattr(os, "geteuid") and os.geteuid() == 0:  # containers often run as root
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    with open(screen, "w", encoding="utf-8") as out:
        # own process group, so that a timeout (or an interrupt) ends mpirun's ranks too
        proc = subprocess.Popen(args, cwd=workdir, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                env=env, start_new_session=True)
        try:
            proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            _kill_group(proc)
            raise SimulationFailed(f"LIGGGHTS ran past its timeout of {timeout_s:.0f} s", _tail(screen),
                                   kind="timeout") from None
        except BaseException:
            _kill_group(proc)
            raise
    if proc.returncode != 0:
        tail = _tail(screen)
        errors = [ln for ln in tail.splitlines() if "ERROR" in ln]
        lost = any("Lost atoms" in ln for ln in errors)
        what = errors[-1].strip() if errors else f"exit status {proc.returncode}"
        raise SimulationFailed(f"LIGGGHTS failed: {what}", tail, kind="unstable" if lost else "crash")
    return screen


def _markers(screen: Path) -> list[list[str]]:
    out = []
    for line in screen.read_text(encoding="utf-8", errors="replace").splitlines():
        if line.startswith("CALIBRAX "):
            out.append(line.split()[1:])
    return out


def _load(path: Path, ncols: int) -> np.ndarray:
    rows = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        parts = line.split()
        if len(parts) < ncols:
            continue
        rows.append([float(v) for v in parts[:ncols]])
    return np.asarray(rows, dtype=float).reshape(-1, ncols)


def poured_density(spec: ShearCellSpec, dump: Path) -> float:
    """The conditioned bulk density of the poured bed, kg/m³, from the dump the script writes after
    the pour (:func:`calibrax.core.sheartest.conditioned_bulk_density`); NaN if it is missing."""
    try:
        lines = dump.read_text().splitlines()
        start = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS")) + 1
        zr = np.asarray([[float(v) for v in line.split()[:2]] for line in lines[start:] if line.strip()], float)
    except (OSError, StopIteration, ValueError):
        return math.nan
    if zr.size == 0:
        return math.nan
    return conditioned_bulk_density(zr[:, 0], zr[:, 1], spec.material.density, spec.bed_cross_section)


def parse_steps(spec: ShearCellSpec, plan: ScriptPlan, workdir: Path, screen: Path
                ) -> tuple[list[StepRecord], list[float], dict[str, float]]:
    """Read the step files and markers of a finished run into StepRecords and bulk densities."""
    marks = _markers(screen)
    tail = _tail(screen)
    begin = {int(m[1]): int(m[2]) for m in marks if m[0] == "begin"}
    end = {int(m[1]): int(m[2]) for m in marks if m[0] == "end"}
    for m in marks:
        if m[0] == "end" and len(m) > 4 and float(m[4]) > 0:
            raise SimulationFailed(f"{float(m[4]):.0f} particles escaped the cell by the end of step {m[1]}", tail,
                                   kind="unstable")
    bulk = {int(m[1]): float(m[2]) for m in marks if m[0] == "bulk"}
    info: dict[str, float] = {}
    placed_step: float | None = None
    for m in marks:
        if m[0] == "poured":
            info["bed_top_after_pour"] = float(m[2])
        elif m[0] == "placed":
            placed_step = float(m[1])
        elif m[0] == "inserted":  # the head's face over the poured bed's top after insertion, radii
            info["insertion_gap_radii"] = (float(m[2]) - float(m[3])) / spec.radius
            info["insertion_reached"] = float(float(m[2]) <= float(m[4]))
        elif m[0] == "consolidated":
            if placed_step is not None:  # the head turns from here until consolidated, s
                info["consolidation_time"] = (float(m[1]) - placed_step) * plan.dt
            info["head_after_consolidation"] = float(m[2])
            info["consolidation_sigma_error"] = float(m[3])
            info["consolidation_settled"] = float(m[4]) if len(m) > 4 else math.nan
        elif m[0] == "done":
            info["total_steps"] = float(m[1])
    # the head's turn back before each settle (script.unload_torque), rad
    unload_start = {int(m[1]): int(m[2]) for m in marks if m[0] == "unload"}
    turned = [spec.procedure.rotation_rate * (int(m[2]) - unload_start[int(m[1])]) * plan.dt
              for m in marks if m[0] == "unloaded" and int(m[1]) in unload_start]
    if turned:
        info["unload_rotation_max"] = float(max(turned))
        info["unload_count"] = float(len(turned))
    if "total_steps" not in info:
        raise SimulationFailed("LIGGGHTS stopped before the end of the procedure", tail, kind="crash")
    radius = spec.geometry.head_radius
    steps: list[StepRecord] = []
    for j, (kind, target, nsamples, fname) in enumerate(plan.steps):
        try:
            ft = _load(workdir / fname, 3)
            zt = _load(workdir / f"z_{fname}", 3)
        except (OSError, ValueError) as exc:
            raise SimulationFailed(f"cannot read LIGGGHTS output {fname}: {exc}", tail, kind="crash") from exc
        s0 = begin.get(j)
        if s0 is not None and j in end:  # a steady preshear ends when its τ/σ is steady: count its samples
            nsamples = (end[j] - s0) // plan.sample_steps
        if s0 is None or ft.shape[0] < nsamples:
            raise SimulationFailed(f"step {j} ({kind}) has {ft.shape[0]} of {nsamples} samples", tail, kind="crash")
        ft = ft[:nsamples]
        z_by_step = {int(round(a)): (b, c) for a, b, c in zt}
        step_no = ft[:, 0].astype(np.int64)
        if not np.all(np.isfinite(ft)):
            raise SimulationFailed(f"NaN in the head force or torque during step {j} ({kind})", tail, kind="nan")
        z = np.asarray([z_by_step.get(int(k), (math.nan, math.nan))[0] for k in step_no])
        spin = np.asarray([z_by_step.get(int(k), (math.nan, math.nan))[1] for k in step_no])
        if np.any(np.isnan(z)):
            raise SimulationFailed(f"head height missing or NaN during step {j} ({kind})", tail, kind="nan")
        time_s = step_no * plan.dt
        rotation = spec.procedure.rotation_rate * (step_no - s0) * plan.dt
        tau = np.asarray(shear_stress_from_torque(ft[:, 2], radius), dtype=float)
        sigma = ft[:, 1] / plan.head_area
        steps.append(StepRecord(kind=kind, target_stress=target, time=time_s, rotation=rotation, shear_stress=tau,
                                normal_stress=sigma, bed_height=z, base_spin=spin))
    n_pre = sum(1 for s in plan.steps if s[0] == "preshear")
    bulk_list = [bulk.get(k, math.nan) for k in range(n_pre)]
    return steps, bulk_list, info


class LiggghtsSimulator:
    """FT4 shear test on LIGGGHTS 3.8 (Debian package ``liggghts``).

    Hertz–Mindlin with tangential history and EPSD2 rolling friction (``pair_style gran model
    hertz tangential history rolling_friction epsd2``, plus ``cohesion sjkr`` when the material is
    cohesive); base, ribs, lateral wall and bladed head as STL meshes under ``fix wall/gran``; the
    head's height is held by a dynamic stress servo (numba_dem's) written as LIGGGHTS variables driving
    ``fix move/mesh linear/variable``, its rotation by ``rotate/variable``. σ, τ, rotation, bed
    height and the fill follow numba_dem's conventions (see :mod:`calibrax_liggghts.script`).

    Args:
        timeout_s: wall-clock limit of one LIGGGHTS run, s (None: no limit).
    """

    name = "liggghts"

    def __init__(self, timeout_s: float | None = 6 * 3600.0) -> None:
        self.timeout_s = timeout_s

    def capabilities(self) -> frozenset[str]:
        """Wall friction, size distributions (explicit radii in the data file), SJKR cohesion,
        base ribs (meshed), rolling friction."""
        return frozenset({"wall_friction", "size_distribution", "cohesion", "base_ribs", "rolling_friction"})

    def version(self) -> str:
        """``LIGGGHTS-PUBLIC 3.8.0`` as the binary reports it (``LIGGGHTS (not found)`` without it)."""
        exe = shutil.which("liggghts")
        if exe is None:
            return "LIGGGHTS (not found)"
        try:
            # in a scratch folder: LIGGGHTS writes log.liggghts wherever it runs, and the probe must
            # not leave one in the user's working folder
            with tempfile.TemporaryDirectory(prefix="calibrax-liggghts-version-") as scratch:
                out = subprocess.run([exe, "-h"], capture_output=True, text=True, timeout=30, check=False,
                                     stdin=subprocess.DEVNULL, cwd=scratch).stdout
        except (OSError, subprocess.TimeoutExpired):
            return "LIGGGHTS (unknown version)"
        m = _VERSION_RE.search(out)
        return m.group(1) if m else "LIGGGHTS (unknown version)"

    def simulate(self, spec: ShearCellSpec, workdir: Path) -> ShearTestResult:
        """Run the whole test; SpecError/ConfigError before anything is written for a bad or
        unsupported spec, EngineNotFound without the binary, SimulationFailed (with the engine's
        output tail) on a crash, lost atoms, NaN or timeout."""
        spec.validate()
        check_capabilities(self, spec)
        find_liggghts()
        workdir = Path(workdir)
        workdir.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        plan = write_inputs(spec, workdir)
        screen = run_liggghts(workdir, threads=spec.numerics.threads, timeout_s=self.timeout_s)
        steps, bulk, info = parse_steps(spec, plan, workdir, screen)
        wall = time.perf_counter() - t0
        errors = [float(np.mean(s.normal_stress) / s.target_stress - 1.0) for s in steps]
        warnings = []
        bad = [e for e in errors if abs(e) > 0.05]
        if bad:
            warnings.append(f"the servo held σ within 5 % of its target in only {len(errors) - len(bad)} of "
                            f"{len(errors)} steps (worst {100 * max(bad, key=abs):+.1f} %)")
        if info.get("insertion_reached", 1.0) < 0.5:
            warnings.append(f"blade insertion: after {insertion_time_limit(spec, APPROACH_SPEED):.3g} s "
                            f"the head's face was still {info['insertion_gap_radii']:.2f} particle radii above the "
                            "poured bed's top: the blades are not fully in the bed")
        if info.get("consolidation_settled", 1.0) < 0.5:
            warnings.append(f"consolidation: the head was still moving after "
                            f"{spec.procedure.consolidation_time_limit:.3g} s "
                            f"({CONSOLIDATION_LIMIT_FACTOR:g} × one preshear rotation)")
        prov = Provenance(backend=self.name, engine_version=self.version(), spec_hash=spec.spec_hash(),
                          seed=spec.numerics.seed, wall_time=wall, particle_count=plan.n_particles,
                          threads=spec.numerics.threads,
                          extra={"time_step": plan.dt, "simulated_time": info["total_steps"] * plan.dt,
                                 "servo_sigma_errors": errors, "stress_area": "pi*head_radius**2",
                                 "plugin_version": __version__, **info})
        return ShearTestResult.from_steps(spec, steps, bulk, prov, warnings,
                                          conditioned_bulk_density=poured_density(spec, workdir / POURED_DUMP))
