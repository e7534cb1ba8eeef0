"""REST API over real uvicorn processes: restart on the same data directory, two servers and
two workers sharing one data directory (docs/design.md, "State")."""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest

from app.schemas import TWO_LINK_URDF
from tests.live import LiveServer

pytestmark = pytest.mark.slow

#: requests sent to a multi-worker server so that every worker is very likely hit
REQUESTS_PER_CHECK = 12


@contextmanager
def server(data_dir: Path, workers: int = 1):
    """A client of a real uvicorn (``tests.live.LiveServer``) serving ``data_dir``."""
    live = LiveServer(data_dir, data_dir.parent / f"uvicorn-{data_dir.name}-{id(data_dir)}.log", workers=workers,
                      env={"KIN_LOG_LEVEL": "warning"})
    with live, httpx.Client(base_url=live.url, timeout=30) as client:
        yield client


def test_restart_and_two_servers_share_the_data_dir(tmp_path):
    data = tmp_path / "data"
    with server(data) as a:
        r = a.post("/models", content=TWO_LINK_URDF, headers={"content-type": "application/xml"})
        assert r.status_code == 201
        mid = r.json()["id"]
        with server(data) as b:
            assert b.post(f"/models/{mid}/fk", json={"q": [0.5, 0.5]}).status_code == 200
            assert b.delete(f"/models/{mid}").status_code == 204
            assert a.get(f"/models/{mid}").status_code == 404
            assert a.post("/models", content=TWO_LINK_URDF, headers={"content-type": "application/xml"}).status_code == 201
            assert b.get(f"/models/{mid}").status_code == 200
    # restart on the same directory: the model is still there
    with server(data) as c:
        info = c.get(f"/models/{mid}")
        assert info.status_code == 200 and info.json()["joint_names"] == ["shoulder", "elbow"]
        pose = c.post(f"/models/{mid}/fk", json={"q": [0.0, 0.0], "links": ["tool"]}).json()["poses"]["tool"]
        assert pose["position"] == [1.0, 0.0, 0.0]


def test_two_workers_behave_as_one_service(tmp_path):
    close = {"connection": "close"}  # a new connection per request, so both workers answer some
    with server(tmp_path / "data", workers=2) as s:
        mid = s.post("/models", json={"urdf": TWO_LINK_URDF}, headers=close).json()["id"]
        for _ in range(REQUESTS_PER_CHECK):  # found by whichever worker answers; both now cache it
            assert s.get(f"/models/{mid}", headers=close).status_code == 200
        assert s.delete(f"/models/{mid}", headers=close).status_code == 204
        for _ in range(REQUESTS_PER_CHECK):  # gone from both caches
            assert s.post(f"/models/{mid}/fk", json={"q": [0.0, 0.0]}, headers=close).status_code == 404
