"""numba_dem's CUDA path (``numerics.device: cuda``) without a GPU: its kernels under Numba's CUDA
simulator (NUMBA_ENABLE_CUDASIM=1, set by tests/conftest.py) against theory and against the CPU path
to round-off, its kernels compiled for a real GPU (full tier), and a CUDA spec refused, exit 2, on
a machine without one."""

from __future__ import annotations

import copy
import logging
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

from calibrax.core.sheartest import ShearCellSpec
from calibrax.core.sheartest.engine_control import RunLog
from calibrax.core.sheartest.procedure_stages import Consolidate, InsertBlades, Pour
from calibrax_numba_dem import verification as V
from calibrax_numba_dem.contact import beta_from_restitution, effective_moduli
from calibrax_numba_dem.cuda_engine import SIMULATOR, CudaDEMSystem
from calibrax_numba_dem.engine import DEMSystem, make_params, numba_threads
from calibrax_numba_dem.layout import H_OMEGA, P_SKIN
from calibrax_numba_dem.procedure import ShearTestDriver
from tests.conftest import calibrax_cli

pytestmark = pytest.mark.numba_dem

RADIUS, DENSITY = 0.9e-3, 3000.0
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_the_suite_runs_the_cuda_path_under_the_simulator() -> None:
    """Everything below runs the CUDA kernels; without a GPU, only the simulator can."""
    assert SIMULATOR, "tests/conftest.py must set NUMBA_ENABLE_CUDASIM=1 before numba.cuda is imported"


def test_hertz_contact_time_and_restitution_on_the_cuda_path() -> None:
    elastic = V.two_sphere_collision(speed=0.5, restitution=1.0, steps_per_contact=200, device="cuda")
    assert elastic["contact_time"] == pytest.approx(elastic["hertz_contact_time"], rel=0.02)
    assert abs(elastic["energy_change"]) < 0.005
    damped = V.two_sphere_collision(speed=0.5, restitution=0.5, steps_per_contact=200, device="cuda")
    assert damped["restitution"] == pytest.approx(0.5, rel=0.02)


def test_sliding_on_the_base_decelerates_at_mu_g_on_the_cuda_path() -> None:
    """A wall contact (the base) with Coulomb sliding: deceleration μs·g."""
    r = V.sliding_on_base(friction=1.0, speed=0.1, dt=4.0e-6, device="cuda")
    assert r["deceleration"] == pytest.approx(r["expected"], rel=0.02)


def test_rolling_torque_saturates_at_mur_r_fn_on_the_cuda_path() -> None:
    r = V.rolling_resistance(rolling_friction=0.5, spin=20.0, dt=4.0e-6, device="cuda")
    assert r["torque"] == pytest.approx(r["expected"], rel=0.02)


def _rot(a: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    out = np.array(a, dtype=float, copy=True)
    out[..., 0] = c * a[..., 0] - s * a[..., 1]
    out[..., 1] = s * a[..., 0] + c * a[..., 1]
    return out


def test_a_particle_crossing_a_sector_face_along_the_walls_is_the_cpu_paths() -> None:
    """A sphere slides and spins along the base and the frictional vessel wall across the face
    θ = π/2 of a quarter sector, the lists rebuilt before every step (so it is wrapped into the
    wedge with its wall history the step after it leaves): the CUDA path's trajectory and forces
    equal the CPU path's to round-off."""
    k, rc, dt = 4, 12.0e-3, 2.0e-7
    e_star, g_star = effective_moduli(1.0e9, 0.25)
    mass = 4.0 / 3.0 * math.pi * RADIUS**3 * DENSITY
    overlap = (mass * 9.81 / (4.0 / 3.0 * e_star * math.sqrt(RADIUS))) ** (2.0 / 3.0)
    theta0 = math.pi / 2 - 0.001
    rho = rc - RADIUS + 2e-7
    x = np.array([[rho * math.cos(theta0), rho * math.sin(theta0), RADIUS - overlap]])
    tangent = np.array([-math.sin(theta0), math.cos(theta0), 0.0])
    v = (1.0 * tangent)[None, :]
    params = make_params(dt=dt, estar=e_star, gstar=g_star, beta=beta_from_restitution(0.5), mu=0.5, mur=0.3,
                         sector=2.0 * math.pi / k, gz=-9.81, use_base=1.0, mu_base=0.4, mur_base=0.2, use_cyl=1.0,
                         rc=rc, mu_wall=0.3, mur_wall=0.1)
    cpu = DEMSystem(x.copy(), np.array([RADIUS]), DENSITY, params.copy(), v=v.copy())
    cpu.w[0] = [3.0, -2.0, 50.0]
    gpu = CudaDEMSystem(x, np.array([RADIUS]), DENSITY, params.copy(), v=v)
    gpu.w[0] = [3.0, -2.0, 50.0]
    ref, got = [], []
    with numba_threads(1):
        for _ in range(120):
            cpu.rebuild_lists()
            gpu.rebuild_lists()
            cpu.advance(1)
            gpu.advance(1)
            ref.append(np.stack([cpu.x, cpu.v, cpu.w, cpu.f]).copy())
            got.append(np.stack([gpu.x, gpu.v, gpu.w, gpu.f]).copy())
    ref, got = np.array(ref), np.array(got)
    theta = np.arctan2(ref[:, 0, 0, 1], ref[:, 0, 0, 0])
    assert theta.min() < 0.5 and theta[0] > 1.5, "the sphere must have crossed the face and been wrapped"
    assert np.count_nonzero(gpu.wid >= 0) == 2, "with its base and wall contacts"
    for k, unit in enumerate((rc, np.abs(ref[:, 1]).max(), np.abs(ref[:, 2]).max(), np.abs(ref[:, 3]).max())):
        np.testing.assert_allclose(got[:, k], ref[:, k], rtol=0, atol=1e-9 * unit, err_msg="xvwf"[k])


def _sector_driver() -> ShearTestDriver:
    spec = ShearCellSpec.preset("tiny").replace(geometry={"sector": 4})
    return ShearTestDriver(spec, RunLog(logging.getLogger("calibrax.tests.cuda")))


@pytest.fixture(scope="module")
def sheared_sector() -> DEMSystem:
    """A quarter sector of ``tiny`` (≈ 140 particles, blades, ribs and the core), consolidated by the
    CPU path and turning under the preshear stress, ten times faster than the test's rate."""
    driver = _sector_driver()
    spec = driver.spec
    with numba_threads(1):
        driver.run_stage(Pour())
        driver.run((InsertBlades(spec.procedure.preshear_stress), Consolidate(spec.procedure.preshear_stress)))
        driver.set_servo(spec.procedure.preshear_stress, 0.05)
        driver.sys.head[H_OMEGA] = 10.0 * spec.procedure.rotation_rate
        driver.sys.advance(20)
    return driver.sys


def _assert_same_state(gpu: CudaDEMSystem, cpu: DEMSystem) -> None:
    """The CUDA path's lists equal the CPU path's; its particles and forces equal to round-off."""
    host = gpu.pull()
    assert gpu.pair_count == cpu.pair_count
    for name, used in (("start", cpu.n + 1), ("rstart", cpu.n + 1), ("pj", cpu.pair_count),
                       ("pimg", cpu.pair_count), ("rpair", cpu.pair_count)):
        np.testing.assert_array_equal(getattr(host, name)[:used], getattr(cpu, name)[:used], err_msg=name)
    np.testing.assert_array_equal(host.wid, cpu.wid)
    scale = {"x": 1e-3, "v": np.abs(cpu.v).max(), "w": np.abs(cpu.w).max(), "f": np.abs(cpu.f).max()}
    for name, unit in scale.items():
        np.testing.assert_allclose(getattr(gpu, name), getattr(cpu, name), rtol=0, atol=1e-9 * unit, err_msg=name)


def test_a_sheared_bed_steps_as_on_the_cpu_path_to_round_off(sheared_sector: DEMSystem) -> None:
    """Sixty steps of the sheared sector on both paths, a list build on the device midway: the lists
    equal, positions, velocities, spins, forces and the head equal to round-off (the paths add the
    head's load in different orders)."""
    cpu = copy.deepcopy(sheared_sector)
    gpu = CudaDEMSystem(None, None, 1.0, None, host=copy.deepcopy(sheared_sector))
    assert gpu.n > 100
    with numba_threads(1):
        cpu.advance(30)
        gpu.advance(30)
        cpu.rebuild_lists()
        gpu.rebuild_lists()
        cpu.advance(30)
    gpu.advance(30)
    _assert_same_state(gpu, cpu)
    np.testing.assert_allclose(gpu.head, cpu.head, rtol=1e-9, atol=1e-12)
    f_cpu, t_cpu, _, n_cpu = cpu.take_accumulators()
    f_gpu, t_gpu, _, n_gpu = gpu.take_accumulators()
    assert n_gpu == n_cpu > 0 and f_gpu == pytest.approx(f_cpu, rel=1e-9) and t_gpu == pytest.approx(t_cpu, rel=1e-9)


def test_a_pouring_sector_builds_the_cpu_paths_lists_on_the_device() -> None:
    """The sector's particles falling, with a thin skin so that the stop flag calls for a list build
    every few steps: sixty steps on both paths give the same lists and the same state to
    round-off."""
    driver = _sector_driver()
    with numba_threads(1):
        driver.sys.advance(2500)
    # a skin of 1/20 of the test's: the falling particles trigger a build every few steps
    driver.sys.params[P_SKIN] *= 0.05
    cpu = copy.deepcopy(driver.sys)
    gpu = CudaDEMSystem(None, None, 1.0, None, host=copy.deepcopy(driver.sys))
    builds = cpu.list_builds
    with numba_threads(1):
        cpu.advance(60)
    gpu.advance(60)
    assert gpu.list_builds == cpu.list_builds > builds + 2, "the lists must have been rebuilt on the device"
    _assert_same_state(gpu, cpu)


def test_a_copy_of_the_cuda_state_steps_on_alone(sheared_sector: DEMSystem) -> None:
    """A fork of the test (a snapshot) is a separate state on the device: stepping the copy leaves
    the original where it was, and the original then steps to the copy's state bit for bit."""
    gpu = CudaDEMSystem(None, None, 1.0, None, host=copy.deepcopy(sheared_sector))
    gpu.advance(5)
    twin = copy.deepcopy(gpu)
    before = gpu.x.copy()
    twin.advance(10)
    np.testing.assert_array_equal(gpu.x, before)
    gpu.advance(10)
    np.testing.assert_array_equal(gpu.x, twin.x)
    np.testing.assert_array_equal(gpu.head, twin.head)


@pytest.mark.slow
def test_every_kernel_compiles_for_a_real_gpu() -> None:
    """The simulator runs the kernels as Python; a real GPU compiles them with NVVM. Compile them
    for sm_90 (the H100/H200's) in a process without the simulator: every kernel gives PTX."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0"}
    code = "from calibrax_numba_dem.cuda_engine import compile_ptx; print(compile_ptx())"
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    sizes = eval(proc.stdout.strip().splitlines()[-1], {})  # noqa: S307 — our own dict literal
    assert {"pair_kernel", "gather_kernel", "head_kernel", "row_kernel", "wrap_particles_kernel"} <= set(sizes)
    assert len(sizes) == 17 and min(sizes.values()) > 1000


def test_a_cuda_campaign_on_a_machine_without_a_gpu_exits_2_naming_the_key(tmp_path) -> None:
    """Without the simulator this machine has no GPU: ``calibrax run`` of a campaign asking for
    ``cell.numerics.device: cuda`` stops with exit code 2, naming the key, before anything runs."""
    campaign = yaml.safe_load(open(os.path.join(ROOT, "examples", "quickstart.yaml"), encoding="utf-8"))
    campaign["cell"]["numerics"]["device"] = "cuda"
    campaign["experiment"] = os.path.join(ROOT, "examples", campaign["experiment"])
    campaign["store"], campaign["workdir"] = str(tmp_path / "store.h5"), str(tmp_path / "runs")
    path = tmp_path / "campaign.yaml"
    path.write_text(yaml.safe_dump(campaign), encoding="utf-8")
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0"}
    proc = calibrax_cli("run", str(path), env=env, timeout=300)
    assert proc.returncode == 2, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "cell.numerics.device" in proc.stderr and "GPU" in proc.stderr, proc.stderr[-2000:]
    assert not (tmp_path / "store.h5").exists() and not (tmp_path / "runs").exists(), "nothing ran or was written"
