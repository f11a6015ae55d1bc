"""The campaign's memory: one crash-safe HDF5 file, and a lock.

Layout (``/`` attrs: format, calibrax version, created, search hash, resolved config as JSON)::

    /points/p000007                 attrs: batch, unit (d,), natural (d,), names, seeds (k,), proposed_at,
                                           fidelity (a multi-fidelity campaign's preset)
    /points/p000007/sim0            attrs: status (done|failed), seed, wall_time, provenance, reason, log_tail
    /points/p000007/sim0/peaks      datasets: peak_shear_stress (k,), peak_normal_stress (k,), …
    /points/p000007/sim0/steps/s00  datasets: time, rotation, shear_stress, normal_stress, bed_height (n,)
    /points/p000007/metric          attrs: value, uncertainty, features (JSON)
    /models/b0003                   attrs: batch, acquisition, hyperparameters (JSON)

HDF5 is not journaled, so every change is written to a copy beside the store, flushed to disk and
renamed over it (``os.replace`` is atomic on POSIX): a kill -9 at any instant leaves either the old
or the new store, never a torn one. A points's proposal is recorded before it runs, so a resumed
campaign re-runs exactly the simulations that were in flight. An exclusive ``flock`` on
``<store>.lock`` keeps two campaigns off one store; the kernel drops it when the holder dies.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import time
from pathlib import Path
from typing import Any, Callable, Iterator

import h5py
import numpy as np

from calibrax.core.data.experiment import Experiment
from calibrax.core.search.metric import MetricValue, terms_as_features
from calibrax.core.search.records import PointRecord, SimulationRecord, Status

#: ``mismatch(stored config, stored experiment)``: why a store cannot be resumed, or None if it can
Mismatch = Callable[[dict[str, Any], "Experiment | None"], "str | None"]
from calibrax.core.sheartest.result import Provenance, ShearTestResult
from calibrax.core.sheartest.steps import StepRecord
from calibrax.errors import StoreError, StoreLockedError

FORMAT = "calibrax-store/1"
#: the experiment's optional per-point arrays (stores written before they existed read as NaN)
EXPERIMENT_ARRAYS = ("measured_normal_stress", "preshear_sigma", "preshear_tau", "bulk_density",
                     "conditioned_bulk_density")
RESULT_ARRAYS = ("peak_shear_stress", "peak_normal_stress", "target_normal_stress", "peak_position",
                 "bulk_density", "preshear_shear_stress", "preshear_normal_stress", "inertial_number",
                 "preshear_rotation", "preshear_drift", "compression_stress", "compression_height")
#: a result's scalars, stored beside its arrays (stores written before they existed read as NaN)
RESULT_SCALARS = ("conditioned_bulk_density",)


def _fsync_path(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _folder_problem(folder: Path) -> str | None:
    """Why a store cannot be written in ``folder`` (None when it can): ``folder`` must be a writable
    folder, or be missing with a writable folder as its parent."""
    allowed = "give a store path in a writable folder (calibrax creates the store's own folder, no more)"
    try:
        if folder.is_dir():
            return None if _writable(folder) else f"folder {folder} is not writable; {allowed}"
        if folder.exists():
            return f"{folder} is not a folder; {allowed}"
        parent = folder.parent
        if parent.is_dir():
            return None if _writable(parent) else \
                f"folder {folder} does not exist and cannot be created: {parent} is not writable; {allowed}"
        if parent.exists():
            return f"folder {folder} cannot be created: {parent} is not a folder; {allowed}"
        return f"folder {folder} does not exist, nor does {parent}; create {folder} first, or {allowed}"
    except OSError as exc:
        return f"folder {folder} cannot be examined ({exc}); {allowed}"


def _writable(folder: Path) -> bool:
    """Whether files can be created (and renamed) in ``folder``."""
    return os.access(folder, os.W_OK | os.X_OK)


class CampaignStore:
    """A campaign's HDF5 store. Use :meth:`open` (which locks) as a context manager."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._lock_fd: int | None = None

    # ------------------------------------------------------------------------- locking
    @property
    def lock_path(self) -> Path:
        return self.path.with_name(self.path.name + ".lock")

    @property
    def tmp_path(self) -> Path:
        return self.path.with_name(self.path.name + ".tmp")

    def check(self, search_hash: str, mismatch: Mismatch | None = None) -> bool:
        """What a run checks of its store, writing nothing (so that ``run --check`` and a refused run
        leave no file behind): :meth:`check_folder`, and that an existing store is a calibrax store
        made for ``search_hash`` (or, with ``mismatch``, one that it finds nothing against: see
        :meth:`_check_belongs`). True if the store exists."""
        self.check_folder()
        if not self.path.exists():
            return False
        with self._read() as f:
            self._check_belongs(f, search_hash, mismatch)
        return True

    def check_folder(self) -> None:
        """Raise :class:`StoreError` unless the store's folder is a writable folder, or is missing
        and its parent is a writable folder (:meth:`acquire` makes that one level, no more)."""
        problem = _folder_problem(self.path.parent)
        if problem:
            raise StoreError(f"store {self.path}: {problem}")

    def in_use(self) -> bool:
        """True while a campaign holds this store's lock (it is running now); creates nothing."""
        try:
            fd = os.open(self.lock_path, os.O_RDONLY)
        except OSError:
            return False
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        finally:
            os.close(fd)
        return False

    def acquire(self, search_hash: str | None = None, mismatch: Mismatch | None = None) -> "CampaignStore":
        """Take the store's exclusive lock or raise :class:`StoreLockedError`. With ``search_hash``,
        :meth:`check` runs first, so that a refused store is refused before its lock file is made;
        without it, only :meth:`check_folder`."""
        if search_hash is None:
            self.check_folder()
        else:
            self.check(search_hash, mismatch)
        try:
            self.path.parent.mkdir(exist_ok=True)
            fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise StoreError(f"store {self.path} cannot be locked: {exc}") from exc
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise StoreLockedError(f"store {self.path} is in use by another campaign (pid {holder}); "
                                   "wait for it to finish or stop it, then run again") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        self._lock_fd = fd
        if self.tmp_path.exists():  # a half-written copy left by a killed campaign
            self.tmp_path.unlink()
        return self

    def release(self) -> None:
        if self._lock_fd is not None:
            fcntl.flock(self._lock_fd, fcntl.LOCK_UN)
            os.close(self._lock_fd)
            self._lock_fd = None

    def __enter__(self) -> "CampaignStore":
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    # ------------------------------------------------------------------------- atomic writes
    def _mutate(self, change: Callable[[h5py.File], Any]) -> Any:
        """Apply ``change`` to a copy of the store, flush it, and rename it over the store."""
        if self._lock_fd is None:
            raise StoreError(f"store {self.path} is not locked for writing")
        tmp = self.tmp_path
        try:
            if self.path.exists():
                shutil.copyfile(self.path, tmp)
            with h5py.File(tmp, "a") as f:
                out = change(f)
                f.flush()
            _fsync_path(tmp)
            os.replace(tmp, self.path)
            _fsync_path(self.path.parent)
        except OSError as exc:
            raise StoreError(f"cannot write store {self.path}: {exc}; the store keeps its last good state") from exc
        return out

    def _read(self) -> h5py.File:
        if not self.path.exists():
            raise StoreError(f"store {self.path} does not exist")
        try:
            # no HDF5 file locking: the store has its own protocol (one writer under the .lock file,
            # each write a new file renamed over the old), and HDF5's lock let a reader (the test's
            # poll, `calibrax status` during a run) make the campaign's own read fail with errno 11
            return h5py.File(self.path, "r", locking=False)
        except OSError as exc:
            raise StoreError(f"store {self.path} cannot be opened as HDF5 ({exc}); give the path of a calibrax "
                             "store, or a new path for a new campaign") from exc

    # ------------------------------------------------------------------------- campaign level
    def initialise(self, search_hash: str, config: dict[str, Any], calibrax_version: str,
                   experiment: Experiment | None = None, mismatch: Mismatch | None = None) -> bool:
        """Create the store for a config (with a copy of the experiment's data, so that the store
        alone can be reported on), or check that it belongs to it. True if it was created."""
        if self.path.exists():
            with self._read() as f:
                self._check_belongs(f, search_hash, mismatch)
            return False

        def create(f: h5py.File) -> None:
            f.attrs["format"] = FORMAT
            f.attrs["calibrax_version"] = calibrax_version
            f.attrs["created"] = time.strftime("%Y-%m-%dT%H:%M:%S%z")
            f.attrs["search_hash"] = search_hash
            f.attrs["config"] = json.dumps(config)
            f.create_group("points")
            f.create_group("models")
            if experiment is not None:
                write_experiment_group(f.create_group("experiment"), experiment)

        self._mutate(create)
        return True

    def _check_belongs(self, f: h5py.File, search_hash: str, mismatch: Mismatch | None = None) -> None:
        """Raise :class:`StoreError` unless the open store ``f`` is a calibrax store made for
        ``search_hash``. A store whose hash differs still belongs when ``mismatch`` (given its
        stored config and experiment) finds nothing against it: a store written before the hash
        ignored the experiment's path, resumed from another folder."""
        if f.attrs.get("format") != FORMAT:
            raise StoreError(f"store {self.path} is not a calibrax store (format {f.attrs.get('format')!r}); "
                             "give a new store path")
        stored = str(f.attrs.get("search_hash"))
        if stored == search_hash:
            return
        why = f"search hash {stored} ≠ {search_hash}"
        if mismatch is not None:
            config = json.loads(f.attrs.get("config", "{}"))
            experiment = read_experiment_group(f["experiment"]) if "experiment" in f else None
            why = mismatch(config, experiment)
            if why is None:
                return
        raise StoreError(f"store {self.path} was made by a campaign with different settings ({why}); give a new "
                         "store path, or restore the campaign file it was made with (only budget, executor and "
                         "paths may change)")

    def config(self) -> dict[str, Any]:
        with self._read() as f:
            return json.loads(f.attrs["config"])

    def add_batch(self, batch: int, unit: np.ndarray, natural: np.ndarray, names: list[str], seeds: list[list[int]],
                  acquisition: str | list[str], model: dict[str, Any] | None,
                  fidelities: list[str] | None = None) -> list[int]:
        """Record proposed points (shape (q, d)) and the model they came from; return their ids.
        ``acquisition``: what proposed them, one for the batch or one per point (an initial design's
        enqueued and Sobol points); ``fidelities``: each point's fidelity preset, in a
        multi-fidelity campaign."""
        sources = [acquisition] * len(unit) if isinstance(acquisition, str) else list(acquisition)

        def add(f: h5py.File) -> list[int]:
            start = len(f["points"])
            ids = []
            for j in range(len(unit)):
                pid = start + j
                g = f["points"].create_group(f"p{pid:06d}")
                g.attrs.update({"batch": batch, "unit": np.asarray(unit[j], float),
                                "natural": np.asarray(natural[j], float), "names": json.dumps(names),
                                "seeds": np.asarray(seeds[j], dtype=np.int64), "acquisition": sources[j],
                                "proposed_at": time.time()})
                if fidelities is not None:
                    g.attrs["fidelity"] = fidelities[j]
                ids.append(pid)
            if model is not None:
                m = f["models"].create_group(f"b{batch:04d}")
                m.attrs.update({"batch": batch, "acquisition": "+".join(dict.fromkeys(sources)),
                                "hyperparameters": json.dumps(model)})
            return ids

        return self._mutate(add)

    def add_simulation(self, point_id: int, index: int, seed: int, result: ShearTestResult | None = None, *,
                       reason: str = "", log_tail: str = "", kind: str = "", wall_time: float = float("nan"),
                       metric: MetricValue | None = None, metric_error: str = "") -> None:
        """Record one finished simulation (a result, or a failure with its reason and log tail), and
        the point's metric when it is the point's last simulation."""

        def add(f: h5py.File) -> None:
            g = f["points"][f"p{point_id:06d}"]
            name = f"sim{index}"
            if name in g:
                del g[name]
            s = g.create_group(name)
            s.attrs.update({"seed": seed, "wall_time": wall_time, "finished_at": time.time()})
            if result is None:
                s.attrs.update({"status": str(Status.FAILED), "reason": reason, "log_tail": log_tail[-8000:], "kind": str(kind)})
            else:
                write_result_group(s, result)
            if metric is not None:
                m = g.require_group("metric")
                m.attrs.update({"value": metric.value, "uncertainty": metric.uncertainty,
                                "features": json.dumps({**terms_as_features(metric.distance_terms),
                                                        **metric.features})})
            if metric_error:
                g.attrs["metric_error"] = metric_error

        self._mutate(add)

    # ------------------------------------------------------------------------- reading
    def points(self) -> list[PointRecord]:
        """Every point in proposal order."""
        out = []
        with self._read() as f:
            for key in sorted(f["points"]):
                g = f["points"][key]
                seeds = [int(s) for s in g.attrs["seeds"]]
                sims = []
                for i, seed in enumerate(seeds):
                    s = g.get(f"sim{i}")
                    if s is None:
                        sims.append(SimulationRecord(i, seed, Status.PENDING))
                        continue
                    sims.append(SimulationRecord(
                        i, seed, Status(str(s.attrs["status"])), float(s.attrs.get("wall_time", np.nan)),
                        str(s.attrs.get("reason", "")), str(s.attrs.get("log_tail", "")), str(s.attrs.get("kind", "")),
                        json.loads(s.attrs.get("provenance", "{}")), json.loads(s.attrs.get("warnings", "[]"))))
                metric = None
                if "metric" in g:
                    m = g["metric"].attrs
                    metric = MetricValue(float(m["value"]), float(m["uncertainty"]), json.loads(m["features"]))
                out.append(PointRecord(int(key[1:]), int(g.attrs["batch"]), np.asarray(g.attrs["unit"], float),
                                       np.asarray(g.attrs["natural"], float), json.loads(g.attrs["names"]),
                                       str(g.attrs["acquisition"]), sims, metric, str(g.attrs.get("fidelity", ""))))
        return out

    def experiment(self) -> Experiment | None:
        """The experiment the campaign was run against, as stored at its start."""
        with self._read() as f:
            return read_experiment_group(f["experiment"]) if "experiment" in f else None

    def write_answer(self, answer: dict[str, Any]) -> None:
        """Store the campaign's current answer (:meth:`calibrax.core.search.answer.Answer.to_dict`)."""
        def put(f: h5py.File) -> None:
            f.attrs["answer"] = json.dumps(answer)

        self._mutate(put)

    def answer(self) -> dict[str, Any] | None:
        """The last stored answer, or None (a campaign that has not fitted a model yet)."""
        with self._read() as f:
            return json.loads(f.attrs["answer"]) if "answer" in f.attrs else None

    def models(self) -> dict[int, dict[str, Any]]:
        """{batch: hyperparameters} of every fitted model."""
        with self._read() as f:
            return {int(g.attrs["batch"]): json.loads(g.attrs["hyperparameters"]) for g in f["models"].values()}

    def result(self, point_id: int, index: int = 0) -> ShearTestResult:
        """The stored result of one simulation."""
        with self._read() as f:
            g = f["points"].get(f"p{point_id:06d}/sim{index}")
            if g is None or g.attrs["status"] != Status.DONE:
                raise StoreError(f"point {point_id} simulation {index} has no result in {self.path}")
            return read_result_group(g)

    def iter_results(self) -> Iterator[tuple[int, int, ShearTestResult]]:
        """(point id, simulation index, result) of every successful simulation."""
        for p in self.points():
            for s in p.sims:
                if s.status == Status.DONE:
                    yield p.id, s.index, self.result(p.id, s.index)


def write_experiment_group(group: h5py.Group, exp: Experiment) -> None:
    group.attrs.update({"name": exp.name, "source": exp.source, "preshear_stress": exp.preshear_stress,
                        "preshear_shear_stress": exp.preshear_shear_stress, "files": json.dumps(list(exp.files))})
    group.create_dataset("normal_stress", data=exp.normal_stress)
    group.create_dataset("peak_shear_stress", data=exp.peak_shear_stress)
    group.create_dataset("replicate", data=exp.replicate)
    group.attrs["wall_friction_angle_deg"] = exp.wall_friction_angle_deg
    group.attrs["material"] = json.dumps(exp.material)
    for key in EXPERIMENT_ARRAYS:
        group.create_dataset(key, data=np.asarray(getattr(exp, key), dtype=float))
    curves = group.create_group("curves")
    for i, ((rep, sigma), (rot, tau)) in enumerate(sorted(exp.curves.items())):
        c = curves.create_group(f"c{i:03d}")
        c.attrs.update({"replicate": rep, "normal_stress": sigma})
        c.create_dataset("rotation", data=rot)
        c.create_dataset("shear_stress", data=tau)
    ramps = group.create_group("compressibility")
    for rep, (sigma, percent) in sorted(exp.compressibility.items()):
        c = ramps.create_group(f"r{rep}")
        c.attrs["replicate"] = rep
        c.create_dataset("normal_stress", data=sigma)
        c.create_dataset("compressibility_percent", data=percent)


def read_experiment_group(group: h5py.Group) -> Experiment:
    curves = {(int(c.attrs["replicate"]), float(c.attrs["normal_stress"])): (c["rotation"][()], c["shear_stress"][()])
              for c in group["curves"].values()}
    a = group.attrs
    optional = {key: group[key][()] for key in EXPERIMENT_ARRAYS if key in group}
    if "compressibility" in group:
        optional["compressibility"] = {int(c.attrs["replicate"]): (c["normal_stress"][()], c["compressibility_percent"][()])
                                       for c in group["compressibility"].values()}
    return Experiment(str(a["name"]), group["normal_stress"][()], group["peak_shear_stress"][()],
                      group["replicate"][()], float(a["preshear_stress"]), float(a["preshear_shear_stress"]),
                      curves, str(a["source"]), tuple(json.loads(a["files"])),
                      wall_friction_angle_deg=float(a.get("wall_friction_angle_deg", np.nan)),
                      material=json.loads(a.get("material", "{}")), **optional)


def write_result_group(group: h5py.Group, result: ShearTestResult) -> None:
    prov = result.provenance
    group.attrs.update({"status": str(Status.DONE), "provenance": json.dumps({
        "backend": prov.backend, "engine_version": prov.engine_version, "spec_hash": prov.spec_hash,
        "seed": prov.seed, "wall_time": prov.wall_time, "particle_count": prov.particle_count,
        "threads": prov.threads, "extra": prov.extra}, default=str), "warnings": json.dumps(list(result.warnings))})
    peaks = group.create_group("peaks")
    for name in RESULT_ARRAYS:
        peaks.create_dataset(name, data=np.asarray(getattr(result, name), dtype=float))
    for name in RESULT_SCALARS:
        peaks.attrs[name] = float(getattr(result, name))
    steps = group.create_group("steps")
    for i, step in enumerate(result.steps):
        s = steps.create_group(f"s{i:02d}")
        s.attrs.update({"kind": step.kind, "target_stress": step.target_stress})
        for ch in StepRecord.CHANNELS:
            s.create_dataset(ch, data=np.asarray(getattr(step, ch), dtype=float))


def read_result_group(group: h5py.Group) -> ShearTestResult:
    prov = json.loads(group.attrs["provenance"])
    steps = []
    for key in sorted(group["steps"]):
        s = group["steps"][key]
        steps.append(StepRecord(str(s.attrs["kind"]), float(s.attrs["target_stress"]),
                                *(s[ch][()] if ch in s else np.empty(0) for ch in StepRecord.CHANNELS)))
    # a store written before a result array existed lacks it: read it as empty
    arrays = {name: group["peaks"][name][()] if name in group["peaks"] else np.empty(0) for name in RESULT_ARRAYS}
    arrays.update({name: float(group["peaks"].attrs.get(name, np.nan)) for name in RESULT_SCALARS})
    return ShearTestResult(steps=tuple(steps), provenance=Provenance(**prov),
                           warnings=tuple(json.loads(group.attrs.get("warnings", "[]"))), **arrays)
