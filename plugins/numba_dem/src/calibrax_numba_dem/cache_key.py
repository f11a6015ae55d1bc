"""The key of numba_dem's kernel cache: a hash of the package's sources.

Numba checks a cached kernel against its own file only, not against the files it inlines from (a
change to contact.py leaves engine.py's cached kernels stale), so the Makefile and the test suite
keep the cache in ``.numba_cache/<key>`` (``NUMBA_CACHE_DIR``), a new folder whenever any source
changes. Standard library only: ``python3 cache_key.py`` prints the key before the virtual
environment exists, and ``tests/conftest.py`` computes the same one for a bare ``pytest``.
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

#: this package's folder
SOURCES = Path(__file__).resolve().parent


def cache_key(folder: Path = SOURCES) -> str:
    """The first 12 hex digits of the SHA-1 of the package's ``*.py`` files, read in name order."""
    digest = hashlib.sha1()
    for path in sorted(Path(folder).glob("*.py"), key=lambda p: p.name):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


if __name__ == "__main__":
    print(cache_key())
    sys.exit(0)
