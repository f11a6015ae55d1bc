"""Compile numba_dem's kernels into Numba's cache once, at set-up (``make setup`` runs
``python -m calibrax_numba_dem.warmup``).

Without it, each of the first simulations on a fresh machine compiles them itself (about 90 s of
CPU each; ``make run``'s two first simulations did it side by side, 113 and 117 s for tests that
take 23 s warm). One two-sphere collision goes through the very kernels a shear test calls, with
the same types (the cache then holds the same entries a shear test writes), so every simulation
after it starts warm. The cache is ``NUMBA_CACHE_DIR`` (the Makefile keys it by a hash of this
package's sources: Numba checks a kernel's own file only, not the files it inlines).
"""

from __future__ import annotations

import os
import sys
import time


def main() -> int:
    t0 = time.perf_counter()
    from .verification import two_sphere_collision

    two_sphere_collision()
    where = os.environ.get("NUMBA_CACHE_DIR", "Numba's default cache (__pycache__ next to the sources)")
    print(f"numba_dem: kernels compiled in {time.perf_counter() - t0:.0f} s, cached in {where}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
