"""What a campaign tells its user while it runs, on the analytic TEST DOUBLE (issue 21): a
simulation "starts" when a worker takes it, not when it is queued; the stored wall time is the
engine's, not its wait in the queue; progress counts simulations and gives the time left; the work
folder is named; a finished campaign run again says it is complete."""

from __future__ import annotations

from calibrax import CampaignStore, load_config, run_campaign
from tests.conftest import write_double_campaign

SLEEP_S = 1.5


def _run(config):
    events = []
    run_campaign(config, listener=events.append)
    return events


def test_progress_of_a_campaign_and_of_its_reruns(tmp_path, monkeypatch):
    monkeypatch.setenv("CALIBRAX_DOUBLE_SLEEP", str(SLEEP_S))
    path = write_double_campaign(tmp_path, budget={"initial": 2, "iterations": 0},
                                 executor={"name": "local", "workers": 1})
    config = load_config(path)
    events = _run(config)
    assert "new campaign" in events[0]["message"] and str(config.workdir) in events[0]["message"]
    kinds = [(e["event"], e.get("point")) for e in events if e["event"] in ("queued", "started", "done")]
    # one worker, q = 2: both are queued at once; the second starts only when the first is done
    assert kinds == [("queued", 0), ("queued", 1), ("started", 0), ("done", 0), ("started", 1), ("done", 1)], kinds
    started = [e for e in events if e["event"] == "started"]
    assert [e["message"].split(":")[0] for e in started] == ["simulation 1 of 2", "simulation 2 of 2"]
    for e in started:
        assert e["workdir"] in e["message"] and e["workdir"].startswith(str(config.workdir)), e
    first_done = next(e for e in events if e["event"] == "done")
    assert "1 of 2 simulations done, about" in first_done["message"] and "s left" in first_done["message"], first_done
    # point 1 waited SLEEP_S in the queue: its stored time is the engine's own, not wait + run
    store = CampaignStore(config.store)
    for p in store.points():
        engine = store.result(p.id).provenance.wall_time
        assert p.sims[0].wall_time == engine and SLEEP_S <= engine < SLEEP_S + 1.0, (p.id, p.sims[0].wall_time)

    # run again: complete, nothing runs
    again = _run(config)
    head = again[0]
    assert head["event"] == "campaign" and head["complete"], head
    assert "campaign complete (2 points, 2 simulations stored; nothing to run)" in head["message"], head["message"]
    assert "resuming" not in head["message"]
    assert not [e for e in again if e["event"] in ("queued", "started", "done")]

    # one more iteration asked for: resuming, and the count goes on from what is stored
    monkeypatch.setenv("CALIBRAX_DOUBLE_SLEEP", "0")
    grown = _run(load_config(write_double_campaign(tmp_path, budget={"initial": 2, "iterations": 1},
                                                   executor={"name": "local", "workers": 1})))
    assert "resuming campaign (2 of 4 simulations stored)" in grown[0]["message"], grown[0]["message"]
    numbers = [e["message"].split(":")[0] for e in grown if e["event"] == "started"]
    assert numbers == ["simulation 3 of 4", "simulation 4 of 4"], numbers
