"""The plugin system: a broken entry-point plugin warns, is listed as broken, and nothing else breaks."""

from __future__ import annotations

import pytest

import os

from calibrax.core.registry import PluginManager
from tests.conftest import calibrax_cli, double_env, write_double_campaign


def make_broken_distribution(folder):
    """An installed-looking distribution whose calibrax plugin module fails to import."""
    info = folder / "brokenplug-0.3.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: brokenplug\nVersion: 0.3\n")
    (info / "entry_points.txt").write_text("[calibrax]\nbroken_backend = brokenplug_module\n")
    (folder / "brokenplug_module.py").write_text("import numpy\nraise ImportError('libfoo.so.1 not found')\n")


def test_broken_entry_point_warns_is_listed_and_others_work(tmp_path):
    make_broken_distribution(tmp_path)
    env = double_env()
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), env["PYTHONPATH"]])
    proc = calibrax_cli("plugins", env=env)
    assert proc.returncode == 0, proc.stderr
    assert "brokenplug" in proc.stderr and "libfoo.so.1 not found" in proc.stderr  # the warning
    assert "broken (skipped):" in proc.stdout and "broken_backend = brokenplug_module from brokenplug" in proc.stdout
    for line in ("metric       c_aif", "acquisition  qei", "executor     local", "simulator    analytic_double"):
        assert line in proc.stdout
    # a campaign still validates with the healthy plugins
    check = calibrax_cli("run", str(write_double_campaign(tmp_path)), "--check", env=env)
    assert check.returncode == 0, check.stderr
    # asking for the broken one names it
    proc = calibrax_cli("run", str(write_double_campaign(tmp_path, simulator="broken_backend")), "--check", env=env)
    assert proc.returncode == 2 and "unknown simulator 'broken_backend'" in proc.stderr and "libfoo" in proc.stderr


def test_builtins_are_registered_like_external_plugins():
    manager = PluginManager()
    manager.load_builtins()
    assert set(manager.plugins("acquisition")) == {"qei", "qlogei", "qnei", "qlognei", "sobol", "random", "mfei", "mfkg"}
    assert manager.plugins("metric")["c_aif"].distribution == "calibrax"
    assert manager.plugins("simulator") == {}


def test_second_campaign_on_a_locked_store_gets_a_lock_error(tmp_path):
    from calibrax import CampaignStore

    path = write_double_campaign(tmp_path, budget={"initial": 2, "iterations": 0})
    holder = CampaignStore(tmp_path / "runs/double.h5").acquire()
    try:
        proc = calibrax_cli("run", str(path))
    finally:
        holder.release()
    assert proc.returncode == 2 and "is in use by another campaign" in proc.stderr
    assert not (tmp_path / "runs/double.h5").exists()


def test_an_install_without_the_builtin_entry_points_says_how_to_fix_it(monkeypatch):
    import importlib.metadata as md

    import pytest

    from calibrax.core.registry import PluginWarning

    monkeypatch.setattr(md, "entry_points", lambda **_: [])  # metadata from before the builtins were entry points
    manager = PluginManager()
    with pytest.warns(PluginWarning, match="reinstall it"):
        manager.load_builtins()
    assert manager.plugins("metric") == {}


def test_plugin_options_are_declared_once_and_checked_in_one_place():
    """``OPTIONS`` declares each option (a plain type still works, for plugins written before
    declarations); :func:`check_options` checks them with one message style, for the campaign file
    and for ``PluginManager.create`` alike."""
    from calibrax.core.options import Option, check_options
    from calibrax.errors import ConfigError

    class PluginDouble:  # test double of a plugin class: only its declaration matters here
        name = "double"
        OPTIONS = {"workers": Option(int, low=1), "rate": Option(float, low=0.0, high=1.0, low_open=True),
                   "mode": Option(str, choices=("a", "b")), "legacy": int}

    assert check_options("executor", PluginDouble, {"workers": 2, "rate": "5e-1", "legacy": 0}) == \
        {"workers": 2, "rate": 0.5, "legacy": 0}
    for given, message in (({"workers": 0}, "executor.workers: must be an integer ≥ 1, got 0"),
                           ({"rate": 0.0}, r"executor.rate: must be in \(0, 1\], got 0.0"),
                           ({"mode": "c"}, r"executor.mode: must be one of \['a', 'b'\], got 'c'"),
                           ({"legacy": 1.5}, "executor.legacy: must be an integer, got 1.5"),
                           ({"speed": 1}, r"executor.speed: unknown option of executor 'double'; allowed: "
                                          r"\['legacy', 'mode', 'rate', 'workers'\]")):
        with pytest.raises(ConfigError, match=message):
            check_options("executor", PluginDouble, given)
