"""The process one simulation runs in: ``python -m calibrax.core.running.isolate TASK.pkl OUTCOME.pkl PARENT_PID``.

Reads the task, runs it, and writes ``("ok", result)`` or ``("failed", reason, log_tail, kind)``
to OUTCOME (aside, then renamed, so a reader never sees half a file). If the parent process
dies, it exits without writing: nobody would read the result, and a resubmitted copy elsewhere
must be the only one to complete.
"""

from __future__ import annotations

import os
import pickle
import sys
import threading
import time
import traceback
from pathlib import Path


def _parent_alive(parent_pid: int) -> bool:
    return os.getppid() == parent_pid


def _watch(parent_pid: int) -> None:
    while True:
        if not _parent_alive(parent_pid):
            os._exit(3)
        time.sleep(0.25)


def main(argv: list[str]) -> int:
    request, outcome, parent = Path(argv[0]), Path(argv[1]), int(argv[2])
    threading.Thread(target=_watch, args=(parent,), daemon=True).start()
    from calibrax.core.running.executor import run_task
    from calibrax.errors import SimulationFailed

    task = pickle.loads(request.read_bytes())
    try:
        message = ("ok", run_task(task))
    except SimulationFailed as exc:
        message = ("failed", exc.reason, exc.log_tail, exc.kind)
    except BaseException as exc:  # noqa: BLE001 — everything else is a crash of this simulation
        message = ("failed", f"{type(exc).__name__}: {exc}", traceback.format_exc()[-4000:], "crash")
    if not _parent_alive(parent):
        return 3
    tmp = outcome.with_suffix(".tmp")
    tmp.write_bytes(pickle.dumps(message))
    os.replace(tmp, outcome)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
