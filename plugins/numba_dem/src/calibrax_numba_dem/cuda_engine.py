"""numba_dem's CUDA path (``numerics.device: cuda``): the CPU path's physics, compiled for the GPU.

One source of the physics, two compilations. The kernels here hold no physics of their own: each
thread calls the very ``njit`` functions the CPU path's parallel loops call, which Numba compiles a
second time as CUDA device functions:

* :func:`~calibrax_numba_dem.engine.pair_row` (one thread per owner particle): the contact law of
  :mod:`contact` on the half neighbour lists, the partner's share left in the pair buffer;
* :func:`~calibrax_numba_dem.engine.gather_row` (one thread per particle): partner shares, the walls
  of :mod:`geometry` (vessel, base, ribs, bladed head, the sector's core), gravity, kick and drift;
* :func:`~calibrax_numba_dem.engine.finish_step` and :func:`~calibrax_numba_dem.geometry.element_directions`
  (one block): the head's servo (:mod:`servo`), its load accumulators and the blades' directions,
  after a fixed-order reduction of the particles' loads (deterministic: the same tree whatever the
  grid).

The state (particles, pair lists and their history, wall slots, head) stays on the device for the
whole test. Steps are queued in chunks of :data:`STEPS_PER_SYNC` with one synchronisation per chunk:
the head kernel raises a stop flag when a particle has moved half the skin since the last list
build, the kernels queued after it return at once, and the host launches a list build on the device
(:mod:`cuda_lists`: the CPU path's wrap and row scan, the same lists in the same order), then goes
on. What comes down is what is read: the head after each call, the particles when the shear test's
checks read them.

Under Numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, what the tests and CI run on a machine
without a GPU) the kernels run on the CPU as Python, thread by thread; the physics functions they
call then run as the CPU path's compiled code on the simulator's arrays
(:func:`~calibrax_numba_dem.cuda_device.device`), so the simulator checks the CUDA path's launches,
indexing, reductions, stop flag and list builds, and :func:`compile_ptx` checks that every kernel
compiles for a real GPU.
"""

from __future__ import annotations

import copy
import math

import numba
import numpy as np
from numba import cuda

from .cuda_device import SIMULATOR, device, per_thread
from .engine import DEMSystem, finish_step, gather_row, max_displacement2, pair_row
from .geometry import element_directions
from .layout import (P_BETA, P_COH, P_DT, P_ESTAR, P_GSTAR, P_GZ, P_MU, P_MUR, P_NBLADES, P_NRIBS, P_SECTOR,
                     P_SKIN)

#: threads of the one block that reduces the particles' loads (a power of two; two under the
#: simulator, which starts a Python thread for every thread of every launch)
REDUCE_THREADS = 2 if SIMULATOR else 256
#: steps queued between two synchronisations with the host
STEPS_PER_SYNC = 64
#: columns of the per-particle loads: upward force on the head (N), the head's resisting torque
#: (N·m), the base's upward force (N), squared displacement since the last list build (m²)
LOAD_COLUMNS = 4
#: slots of the status array: the stop flag (a list build is due) and the steps done in this chunk
S_STOP = 0
S_DONE = 1


def cuda_available() -> bool:
    """Whether a CUDA GPU (or the simulator) can run the CUDA path here."""
    try:
        return bool(cuda.is_available())
    except Exception:  # noqa: BLE001 — a broken driver install is "no GPU" too
        return False


_pair_row = device(pair_row)
_gather_row = device(gather_row)
_finish_step = device(finish_step)
_element_directions = device(element_directions)


@cuda.jit
def pair_kernel(status, x, v, w, rad, mass, start, pj, pimg, hist, rhist, pf, fo, params):
    """:func:`~calibrax_numba_dem.engine.pair_row` of every particle, one thread each (no-op once
    the stop flag is up). Shapes as :func:`~calibrax_numba_dem.engine.pair_forces`."""
    if status[S_STOP] != 0:
        return
    i = cuda.grid(1)
    if i >= x.shape[0]:
        return
    opening = params[P_SECTOR]
    _pair_row(i, x, v, w, rad, mass, start, pj, pimg, hist, rhist, pf, fo, params[P_DT], params[P_ESTAR],
              params[P_GSTAR], params[P_BETA], params[P_MU], params[P_MUR], params[P_COH], math.cos(opening),
              math.sin(opening))


@cuda.jit
def gather_kernel(status, x, v, w, f, t, rad, mass, inertia, rstart, rpair, pf, fo, params, head, dirs, wid,
                  whist, wrhist, x_build, kick, loads):
    """:func:`~calibrax_numba_dem.engine.gather_row` of every particle, one thread each, its loads
    into ``loads`` (N, LOAD_COLUMNS) (no-op once the stop flag is up)."""
    if status[S_STOP] != 0:
        return
    i = cuda.grid(1)
    if i >= x.shape[0]:
        return
    fh, th, fb, d2 = _gather_row(i, x, v, w, f, t, rad, mass, inertia, rstart, rpair, pf, fo, params, head, dirs,
                                 wid, whist, wrhist, x_build, kick, params[P_DT], params[P_GZ])
    loads[i, 0] = fh
    loads[i, 1] = th
    loads[i, 2] = fb
    loads[i, 3] = d2


@cuda.jit
def head_kernel(status, loads, params, head, dirs, limit):
    """One block of REDUCE_THREADS threads: the particles' loads summed (displacements: their
    maximum) in a fixed order, then the head's step (:func:`~calibrax_numba_dem.engine.finish_step`),
    the blades' directions for the next step, the step counted, and the stop flag raised when the
    largest squared displacement exceeds ``limit`` (m²)."""
    if status[S_STOP] != 0:
        return
    k = cuda.threadIdx.x
    part = cuda.shared.array((REDUCE_THREADS, LOAD_COLUMNS), numba.float64)
    n = loads.shape[0]
    fh = 0.0
    th = 0.0
    fb = 0.0
    d2 = 0.0
    for i in range(k * n // REDUCE_THREADS, (k + 1) * n // REDUCE_THREADS):
        fh += loads[i, 0]
        th += loads[i, 1]
        fb += loads[i, 2]
        if loads[i, 3] > d2:  # not max(): see compile_ptx
            d2 = loads[i, 3]
    part[k, 0] = fh
    part[k, 1] = th
    part[k, 2] = fb
    part[k, 3] = d2
    cuda.syncthreads()
    half = REDUCE_THREADS // 2
    while half > 0:
        if k < half:
            part[k, 0] += part[k + half, 0]
            part[k, 1] += part[k + half, 1]
            part[k, 2] += part[k + half, 2]
            if part[k + half, 3] > part[k, 3]:
                part[k, 3] = part[k + half, 3]
        cuda.syncthreads()
        half //= 2
    if k == 0:
        _finish_step(head, part[0, 0], part[0, 1], part[0, 2], params[P_DT])
        _element_directions(params, head, dirs)
        status[S_DONE] += 1
        if part[0, 3] > limit:
            status[S_STOP] = 1


@cuda.jit
def directions_kernel(params, head, dirs):
    """The blades' and ribs' directions from the head's angle (one thread), before a chunk."""
    if cuda.grid(1) == 0:
        _element_directions(params, head, dirs)


#: the arrays of :class:`DEMSystem` that the device holds and the host mirrors: the particles, the
#: wall slots, the pair lists and their history, the reverse index, the positions at the last build
_STATE = ("x", "v", "w", "wid", "whist", "wrhist", "start", "pj", "pimg", "hist", "rhist", "rstart", "rpair",
          "x_build")
#: the pair-indexed ones among them, with a capacity that grows when the lists overflow
_PAIRED = ("pj", "pimg", "hist", "rhist", "rpair")
#: the list build's second set of lists (the new lists are written there, then swapped in)
_SCRATCH = ("start", "pj", "pimg", "hist", "rhist")
_CONSTANT = ("rad", "mass", "inertia")


class CudaDEMSystem:
    """:class:`~calibrax_numba_dem.engine.DEMSystem`'s interface, stepping on a CUDA device.

    The whole state lives on the device, the neighbour-list builds included
    (:class:`~calibrax_numba_dem.cuda_lists.DeviceLists`). The host keeps a :class:`DEMSystem`
    (``host``) as the mirror it reads into. ``params`` and ``head`` are the host's arrays: change
    them between calls of :meth:`advance`, which sends them up and brings the head back. ``x``,
    ``v`` and ``w`` come down when read (and go back up at the next :meth:`advance`, in case they
    were changed); ``f`` and ``t`` come down when read.
    """

    def __init__(self, x: np.ndarray, rad: np.ndarray, density: float, params: np.ndarray,
                 head: np.ndarray | None = None, v: np.ndarray | None = None, pair_capacity: int = 0,
                 host: DEMSystem | None = None):
        if not cuda_available():
            from calibrax.errors import SpecError

            raise SpecError("numerics.device", "cuda needs a CUDA GPU, and none is visible here "
                            "(numba.cuda.is_available() is False); use cpu")
        from .cuda_lists import DeviceLists

        # the mirror owns its arrays (DEMSystem keeps a caller's contiguous array as its own)
        self.host = host if host is not None else DEMSystem(
            np.array(x, dtype=np.float64), rad, density, params, head=head,
            v=None if v is None else np.array(v, dtype=np.float64), pair_capacity=pair_capacity)
        h = self.host
        self.params = h.params
        self.head = h.head
        self._d: dict = {}
        for name in (*_STATE, *_CONSTANT, "f", "t"):
            self._d[name] = cuda.to_device(getattr(h, name))
        self._alloc_scratch()
        self._d["loads"] = cuda.device_array((h.n, LOAD_COLUMNS))
        self._d["fo"] = cuda.device_array((h.n, 6))
        self._d["dirs"] = cuda.to_device(np.zeros((max(1, int(h.params[P_NBLADES]) + int(h.params[P_NRIBS])), 2)))
        self._d["params"] = cuda.to_device(h.params)
        self._d["head"] = cuda.to_device(h.head)
        self.lists = DeviceLists(h.n, 2.0 * float(np.max(h.rad)) + float(h.params[P_SKIN]), h.cell_size,
                                 float(h.params[P_SKIN]))
        self.total = h.pair_count
        # a build is due at once unless the host's lists are current (x_build far away forces one)
        due = max_displacement2(h.x, h.x_build) > self._limit()
        self._d["status"] = cuda.to_device(np.array([1 if due else 0, 0], dtype=np.int64))
        self._fresh: set[str] = {*_STATE, "f", "t"}
        self._lent: set[str] = set()
        self._started = host is not None and getattr(host, "_started", False)

    # ------------------------------------------------------------------------------------ state
    def _alloc_scratch(self) -> None:
        """The pair buffer and the build's second set of lists, at the pair arrays' capacity."""
        d = self._d
        d["pf"] = cuda.device_array((d["pj"].shape[0], self.host.pf.shape[1]))
        for name in _SCRATCH:
            d[name + "2"] = cuda.device_array_like(d[name])

    def _grow_pairs(self, capacity: int) -> None:
        """Room for ``capacity`` pairs, the current lists kept (through the host: it is rare)."""
        d = self._d
        for name in _PAIRED:
            old = d[name].copy_to_host()
            new = np.zeros((capacity, *old.shape[1:]), dtype=old.dtype)
            new[:old.shape[0]] = old
            d[name] = cuda.to_device(new)
        self._alloc_scratch()

    def _limit(self) -> float:
        skin = self.host.params[P_SKIN]
        return 0.25 * skin * skin

    def _down(self, name: str) -> np.ndarray:
        """The host's copy of device array ``name``, brought down unless it is already current."""
        if name not in self._fresh:
            h = self.host
            if name in _PAIRED and getattr(h, name).shape[0] != self._d[name].shape[0]:
                h._alloc_pairs(self._d[name].shape[0])
                self._fresh.difference_update(_PAIRED)
            self._d[name].copy_to_host(getattr(h, name))
            self._fresh.add(name)
        return getattr(self.host, name)

    def read(self, name: str) -> np.ndarray:
        """The host's copy of state array ``name``, to read, not to change: it is not sent back up
        (the shear test's checks read the particles this way, once per sample)."""
        return self._down(name)

    def _lend(self, name: str) -> np.ndarray:
        self._lent.add(name)
        return self._down(name)

    x = property(lambda self: self._lend("x"), doc="Positions, shape (N, 3), m.")
    v = property(lambda self: self._lend("v"), doc="Velocities, shape (N, 3), m/s (half a step behind x).")
    w = property(lambda self: self._lend("w"), doc="Angular velocities, shape (N, 3), rad/s.")
    f = property(lambda self: self._down("f"), doc="Forces of the last step, shape (N, 3), N (read only).")
    t = property(lambda self: self._down("t"), doc="Torques of the last step, shape (N, 3), N·m (read only).")
    wid = property(lambda self: self._down("wid"), doc="Wall slots' elements, shape (N, WALL_SLOTS) (read only).")
    rad = property(lambda self: self.host.rad)
    mass = property(lambda self: self.host.mass)
    inertia = property(lambda self: self.host.inertia)
    n = property(lambda self: self.host.n, doc="Particle count.")
    pair_count = property(lambda self: self.total, doc="Pairs in the current half lists.")
    list_builds = property(lambda self: self.host.list_builds, doc="Neighbour-list builds so far.")

    def _send_lent(self) -> None:
        """Send the arrays lent out since the last step back up (the caller may have changed them);
        a moved particle may make a list build due, as on the CPU path."""
        for name in self._lent:
            self._d[name].copy_to_device(getattr(self.host, name))
        if "x" in self._lent and max_displacement2(self.host.x, self._down("x_build")) > self._limit():
            self._d["status"].copy_to_device(np.array([1, 0], dtype=np.int64))
        self._lent.clear()

    def pull(self) -> DEMSystem:
        """The host mirror with the whole state brought down (lists included)."""
        for name in (*_STATE, "f", "t"):
            self._down(name)
        self.host._started = self._started
        return self.host

    # ---------------------------------------------------------------------------------- builds
    def _rebuild(self) -> None:
        """A list build on the device (the sector's wrap first), the pair arrays grown if needed."""
        opening = float(self.params[P_SECTOR])
        while True:
            total = self.lists.build(self._d, self._d["params"], opening)
            if total <= self._d["pj"].shape[0]:
                break
            self._grow_pairs(int(total * 1.5) + 64)
        self.total = total
        self.host.list_builds += 1
        self._fresh.clear()

    def rebuild_lists(self) -> int:
        """Rebuild the neighbour lists now, as :meth:`advance` does when one is due; returns the
        pair count."""
        self._send_lent()
        self._d["params"].copy_to_device(self.params)
        self._rebuild()
        self._d["status"].copy_to_device(np.array([0, 0], dtype=np.int64))
        return self.total

    # -------------------------------------------------------------------------------- stepping
    def advance(self, nsteps: int) -> None:
        """Advance ``nsteps`` time steps on the device (the lists rebuilt whenever one is due)."""
        if nsteps <= 0:
            return
        d = self._d
        self._send_lent()
        d["params"].copy_to_device(self.params)
        d["head"].copy_to_device(self.head)
        pairs = per_thread(pair_kernel, self.host.n)  # configured once: launched every step
        gather = per_thread(gather_kernel, self.host.n)
        limit = self._limit()
        status = d["status"].copy_to_host()
        done = 0
        directions_kernel[1, 1](d["params"], d["head"], d["dirs"])
        while done < nsteps:
            if status[S_STOP]:
                self._rebuild()
            d["status"].copy_to_device(np.array([0, 0], dtype=np.int64))
            for _ in range(min(STEPS_PER_SYNC, nsteps - done)):
                kick = 1.0 if self._started else 0.5
                self._started = True
                pairs(d["status"], d["x"], d["v"], d["w"], d["rad"], d["mass"], d["start"], d["pj"], d["pimg"],
                      d["hist"], d["rhist"], d["pf"], d["fo"], d["params"])
                gather(d["status"], d["x"], d["v"], d["w"], d["f"], d["t"], d["rad"], d["mass"], d["inertia"],
                       d["rstart"], d["rpair"], d["pf"], d["fo"], d["params"], d["head"], d["dirs"], d["wid"],
                       d["whist"], d["wrhist"], d["x_build"], kick, d["loads"])
                head_kernel[1, REDUCE_THREADS](d["status"], d["loads"], d["params"], d["head"], d["dirs"], limit)
            status = d["status"].copy_to_host()
            done += int(status[S_DONE])
            self._fresh.clear()
        d["head"].copy_to_host(self.head)

    def take_accumulators(self) -> tuple[float, float, float, int]:
        """As :meth:`DEMSystem.take_accumulators` (the head is on the host between steps)."""
        return self.host.take_accumulators()

    def kinetic_energy(self) -> float:
        """Translational + rotational kinetic energy, J."""
        self._down("v")
        self._down("w")
        return self.host.kinetic_energy()

    def __deepcopy__(self, memo) -> "CudaDEMSystem":
        """A copy of the whole state on the device (through the host), for a fork of the test."""
        self._send_lent()
        status = self._d["status"].copy_to_host()
        host = copy.deepcopy(self.pull(), memo)
        twin = CudaDEMSystem(None, None, 1.0, None, host=host)
        twin._d["status"].copy_to_device(status)
        return twin


def compile_ptx(compute_capability: tuple[int, int] = (9, 0)) -> dict[str, int]:
    """Compile every kernel for a real GPU of ``compute_capability`` (no GPU needed: libNVVM from a
    CUDA toolkit), with the argument types the CUDA path launches them with. Returns the PTX size
    of each kernel, characters; raises Numba's error where a kernel does not compile. Must run in a
    process without the simulator."""
    if SIMULATOR:
        raise RuntimeError("compile_ptx needs the real CUDA target: unset NUMBA_ENABLE_CUDASIM")
    from numba import float64, int8, int64

    f1, f2, i1, i2 = float64[::1], float64[:, ::1], int64[::1], int64[:, ::1]
    signatures = {
        "pair_kernel": (pair_kernel, (i1, f2, f2, f2, f1, f1, i1, i1, int8[::1], f2, f2, f2, f2, f1)),
        "gather_kernel": (gather_kernel, (i1, f2, f2, f2, f2, f2, f1, f1, f1, i1, i1, f2, f2, f1, f1, f2, i2, f2,
                                          f2, f2, float64, f2)),
        "head_kernel": (head_kernel, (i1, f2, f1, f1, f2, float64)),
        "directions_kernel": (directions_kernel, (f1, f1, f2)),
    }
    from numba import boolean

    from . import cuda_lists as L

    i8, f = int8[::1], float64
    signatures.update({
        "wrap_particles_kernel": (L.wrap_particles_kernel, (f2, f2, f2, i2, f2, f2, i1, f1)),
        "wrap_pairs_kernel": (L.wrap_pairs_kernel, (i1, i1, i8, f2, f2, i1, f1)),
        "near_faces_kernel": (L.near_faces_kernel, (f2, f, f, i1, i1)),
        "images_kernel": (L.images_kernel, (f2, i1, i1, f, f2, i1, i1)),
        "bounds_kernel": (L.bounds_kernel, (f2, int64, f, f1, i1, i1)),
        "cell_count_kernel": (L.cell_count_kernel, (f2, int64, f1, i1, f, i1, i1)),
        "claim_kernel": (L.claim_kernel, (i1, int64, i1, i1, i1)),
        "sort_ranges_kernel": (L.sort_ranges_kernel, (i1, int64, i1)),
        "row_kernel": (L.row_kernel, (f2, f2, i1, i1, f1, f, f1, i1, f, i1, i1, i1, i1, i8, f2, f2, i1, i1, i8, f2,
                                      f2, i1, boolean)),
        "scan_kernel": (L.scan_kernel, (i1, int64, i1)),
        "zero_kernel": (L.zero_kernel, (i1, int64)),
        "copy_rows_kernel": (L.copy_rows_kernel, (f2, f2)),
        "partner_count_kernel": (L._partner_count_kernel, (i1, int64, i1)),
    })
    from types import SimpleNamespace
    from unittest import mock

    import numba.cuda.dispatcher

    # Numba asks the current device for its compute capability when it compiles a device function
    # that is not inlined (element_directions, the servo): with no GPU here, one of
    # ``compute_capability`` stands in for it, for this compilation only
    stand_in = SimpleNamespace(compute_capability=compute_capability)
    out = {}
    with mock.patch.object(numba.cuda.dispatcher, "get_current_device", lambda: stand_in):
        for name, (kernel, sig) in signatures.items():
            ptx, _ = cuda.compile_ptx(kernel.py_func, sig, cc=compute_capability)
            out[name] = len(ptx)
    return out
