"""A failed store write (here: a disk that fills up, injected into the copy step) stops the campaign
with a clear StoreError, leaves the store readable at its last good state, and a rerun resumes."""

from __future__ import annotations

import errno
import shutil

import h5py
import pytest

from calibrax import CampaignStore, load_config, run_campaign
from calibrax.errors import StoreError
from tests.conftest import write_double_campaign


def test_disk_full_during_a_store_write(tmp_path, monkeypatch):
    config = load_config(write_double_campaign(tmp_path, budget={"initial": 4, "iterations": 1}))
    real_copy = shutil.copyfile
    calls = {"n": 0}

    def filling_disk(src, dst, *args, **kwargs):  # fault injection: the 4th store write finds the disk full
        calls["n"] += 1
        if calls["n"] == 4:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_copy(src, dst, *args, **kwargs)

    monkeypatch.setattr(shutil, "copyfile", filling_disk)
    with pytest.raises(StoreError, match="cannot write store .*No space left on device.*last good state"):
        run_campaign(config)
    with h5py.File(config.store, "r") as f:
        assert len(f["points"]) == 4
    done_before = sum(p.status == "done" for p in CampaignStore(config.store).points())
    assert done_before == 2  # copies 1-3: batch 0 and two results; the third result hit the full disk
    monkeypatch.setattr(shutil, "copyfile", real_copy)
    summary = run_campaign(config)
    assert summary.points == 6 and summary.done == 6
