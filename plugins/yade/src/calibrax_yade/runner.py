"""Finding and running the ``yade`` binary, and writing its validated parameter files."""

from __future__ import annotations

import functools
import json
import math
import os
import shutil
import subprocess
from importlib import resources
from pathlib import Path
from typing import Any

from calibrax.errors import EngineNotFound, SimulationFailed, SpecError

__all__ = ["find_yade", "yade_version", "script_path", "check_numbers", "write_params", "run_yade", "log_tail",
           "WORDS"]

#: the only text a parameter file may hold: the stage names the script dispatches on and the kinds
#: of record a rotation writes (calibrax_yade.simulator.stage_params); never text from a config
WORDS = frozenset({"pour", "insert_blades", "consolidate", "settle", "rotate", "preshear", "shear"})

INSTALL_HINT = "install it with `apt-get install -y yade` (Debian/Ubuntu), or set CALIBRAX_YADE to its path"


def find_yade(executable: str | None = None) -> str:
    """The path of the yade binary: ``executable``, else $CALIBRAX_YADE, else ``yade`` on PATH.

    Raises:
        EngineNotFound: no such executable.
    """
    name = executable or os.environ.get("CALIBRAX_YADE") or "yade"
    path = shutil.which(name)
    if path is None:
        raise EngineNotFound(f"the YADE binary {name!r} was not found; {INSTALL_HINT}")
    return path


@functools.lru_cache(maxsize=8)
def yade_version(path: str) -> str:
    """``"YADE <version>"`` from ``yade --version`` (cached per binary)."""
    try:
        out = subprocess.run([path, "--version"], capture_output=True, text=True, timeout=120).stdout
    except (OSError, subprocess.TimeoutExpired):
        return "YADE (unknown version)"
    for line in out.splitlines():
        if "version" in line.lower():
            return "YADE " + line.split(":", 1)[-1].strip()
    return "YADE (unknown version)"


def script_path(name: str) -> Path:
    """The packaged YADE script ``scripts/<name>`` (a fixed file, never generated)."""
    return Path(str(resources.files("calibrax_yade") / "scripts" / name))


def check_numbers(value: Any, key: str = "params") -> None:
    """Raise SpecError unless ``value`` is built only of finite floats/ints (bool excluded), words
    of :data:`WORDS`, lists of them, and dicts with str keys of them — the only things a parameter
    file may hold."""
    if isinstance(value, str) and value in WORDS:
        return
    if isinstance(value, bool) or value is None:
        raise SpecError(key, f"must be a finite number, got {value!r}")
    if isinstance(value, (int, float)):
        if not math.isfinite(value):
            raise SpecError(key, f"must be a finite number, got {value!r}")
        return
    if isinstance(value, (list, tuple)):
        for k, v in enumerate(value):
            check_numbers(v, f"{key}[{k}]")
        return
    if isinstance(value, dict):
        for k, v in value.items():
            if not isinstance(k, str) or not k.isidentifier():
                raise SpecError(key, f"bad parameter name {k!r}")
            check_numbers(v, f"{key}.{k}")
        return
    raise SpecError(key, f"must be a finite number, got {type(value).__name__} {value!r}")


def write_params(path: Path, params: dict[str, Any]) -> Path:
    """Validate ``params`` (finite numbers only) and write them as JSON; returns the path."""
    check_numbers(params)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(params, allow_nan=False))
    os.replace(tmp, path)
    return path


def log_tail(*paths: Path, lines: int = 40) -> str:
    """The last ``lines`` lines of each existing file, concatenated."""
    out = []
    for p in paths:
        if p.exists():
            text = p.read_text(errors="replace").splitlines()
            out.append(f"--- {p.name} ---")
            out.extend(text[-lines:])
    return "\n".join(out)


def run_yade(yade: str, script: Path, params: Path, workdir: Path, threads: int, timeout: float,
             logs: tuple[Path, ...] = ()) -> None:
    """Run ``yade -n -j threads -x script params`` in ``workdir`` (argument list, no shell).

    Raises:
        SimulationFailed: timeout (kind "timeout"), a failure reported by the script
            (failure.json: its kind), or any non-zero exit (kind "crash"); always with the log tail.
    """
    stdout = workdir / "yade_stdout.log"
    cmd = [yade, "-n", "-j", str(int(threads)), "-x", str(script), str(params)]
    env = dict(os.environ)
    env.setdefault("OMP_NUM_THREADS", str(int(threads)))
    try:
        with open(stdout, "w") as out:
            proc = subprocess.run(cmd, cwd=workdir, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                  timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        raise SimulationFailed(f"YADE ran past its timeout of {timeout:.0f} s", log_tail(*logs, stdout),
                               kind="timeout") from None
    failure = workdir / "failure.json"
    if failure.exists():
        info = json.loads(failure.read_text())
        raise SimulationFailed(str(info.get("reason", "YADE script failed")), log_tail(*logs, stdout),
                               kind=str(info.get("kind", "crash")))
    if proc.returncode != 0:
        raise SimulationFailed(f"YADE exited with status {proc.returncode}", log_tail(*logs, stdout), kind="crash")
