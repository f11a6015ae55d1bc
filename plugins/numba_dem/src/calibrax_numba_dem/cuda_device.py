"""How numba_dem's CUDA kernels call the CPU path's ``njit`` functions: one source of the physics and
of the list build, compiled for the CPU and, a second time, for the GPU.

On a GPU a kernel calls the ``njit`` dispatcher itself, which Numba compiles as a device function.
Under Numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``: the tests and CI, which have no GPU) a
kernel runs as Python and its arrays are the simulator's wrappers, which compiled code cannot take;
:func:`device` then calls the function's compiled CPU code on the numpy arrays behind them.
"""

from __future__ import annotations

import numba
import numpy as np

#: whether Numba's CUDA simulator stands in for a GPU (NUMBA_ENABLE_CUDASIM=1)
SIMULATOR = bool(numba.config.ENABLE_CUDASIM)
#: threads per block of the kernels that run one thread per particle, pair or cell
THREADS_PER_BLOCK = 128


def threads_per_block(count: int) -> int:
    """Threads per block for ``count`` threads: THREADS_PER_BLOCK, or fewer for a small count
    (whole warps on a GPU, exactly ``count`` under the simulator, which starts a Python thread per
    thread)."""
    if SIMULATOR:
        return max(1, min(THREADS_PER_BLOCK, count))
    return max(32, min(THREADS_PER_BLOCK, 32 * ((count + 31) // 32)))


def per_thread(kernel, count: int):
    """``kernel`` configured for ``count`` threads (at least one block)."""
    per_block = threads_per_block(count)
    return kernel[max(1, (count + per_block - 1) // per_block), per_block]


def device(fn):
    """``fn`` (an ``njit`` function) as the kernels call it."""
    if not SIMULATOR:
        return fn

    def call(*args):
        return fn(*[_unwrap(a) for a in args])

    return call


def _unwrap(arg):
    """The numpy array behind a simulator's in-kernel array; anything else as it is."""
    item = getattr(arg, "_item", None) if not isinstance(arg, (int, float, np.ndarray)) else None
    return arg if item is None else item._ary
