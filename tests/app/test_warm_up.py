"""The worker's warm-up (app/warm.py): by default in the background, /health telling when it is done."""

from __future__ import annotations

import time

import httpx

from tests.live import LiveServer

#: how long the background warm-up may take before the test gives up (a first start compiles: minutes)
WARM_UP_DEADLINE = 1800.0


def test_a_server_answers_while_it_warms_up_and_health_says_when_it_is_done(tmp_path):
    with LiveServer(tmp_path / "data", tmp_path / "uvicorn.log", env={"KIN_WARM_UP": "background"}) as live, \
            httpx.Client(base_url=live.url, timeout=600.0) as client:
        first = client.get("/health").json()
        assert first["status"] == "ok" and first["warm_up"] in ("running", "done")
        # a request while it warms up is answered, and right
        r = client.post("/models/ur5/fk", json={"q": [0.0] * 6, "links": ["base_link"]})
        assert r.status_code == 200 and r.json()["poses"]["base_link"]["position"] == [0.0, 0.0, 0.0]
        deadline = time.monotonic() + WARM_UP_DEADLINE
        while (state := client.get("/health").json()["warm_up"]) == "running" and time.monotonic() < deadline:
            time.sleep(0.5)
        assert state == "done", live.log()
        log = live.log()
    assert "warm-up: loading the compiled kernels in the background" in log
    assert "warm-up: the bundled models, read and compiled (" in log and "warm-up: done in " in log


def test_before_serving_the_lifespan_waits_for_it(make_client):
    client = make_client(warm_up="before_serving")
    assert client.get("/health").json()["warm_up"] == "done"


def test_a_background_warm_up_leaves_nothing_for_the_collector_to_traverse(monkeypatch):
    """A background warm-up runs after the worker's start froze its heap (app.heavy.configure_process):
    what it leaves alive is frozen too when it ends, else every full collection traversed it with the
    GIL held (~135,000 objects, 50-100 ms in which the event loop answered nothing)."""
    import gc

    from app import warm

    kept: list = []
    monkeypatch.setattr(warm, "steps", lambda catalogue: [("objects", lambda: kept.extend([i] for i in range(20_000)))])
    warm_up = warm.WarmUp()
    warm_up.start(background=True)
    assert warm_up.wait(120) and warm_up.state == "done"
    tracked = {id(o) for o in gc.get_objects()}  # the generations a collection traverses (not the frozen one)
    assert len(kept) == 20_000 and not any(id(o) in tracked for o in kept)
