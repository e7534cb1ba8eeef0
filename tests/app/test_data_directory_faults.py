"""Faults of the data directory, against a real server process (``tests/live.py``).

* a full disk (a tmpfs of a few hundred kB): uploads are refused with a 507 problem, every model
  answered 201 is still there byte for byte, no temporary file or orphan sidecar is left, and
  uploads work again once models are deleted;
* the data directory remounted read-only under the running server: writes (upload, rename,
  delete) answer a 507 naming the cause, reads keep working, a server starts on it, and writes
  work again once it is read-write;
* ``kill -9`` while a large upload is half received, then a restart: nothing half-written is
  listed or left, and the same upload then succeeds;
* stored files damaged while the server was down (truncated, a flipped bit, emptied, a FIFO, a
  directory, a sidecar with fields of the wrong type or missing): the server starts, the intact
  models work, and the damaged ones answer a problem, never a 500; an old temporary file of a
  write killed half-way is removed at start-up, a recent one (maybe another process's) kept.

The tmpfs tests need root (``mount``); they skip cleanly elsewhere. Every wait is on a condition
(the server answers, the upload is read by the server), never on a sleep that must be long enough.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import socket
import subprocess
import time
from pathlib import Path

import httpx
import pytest

from tests.live import LiveServer

PROBLEM = "application/problem+json"
TIMEOUT = 60.0
#: links of each uploaded chain (about 60 kB of URDF)
CHAIN_LINKS = 300
#: the full-disk tmpfs: room for a handful of chains and their sidecars
FULL_DISK_SIZE = "512k"
#: most uploads tried before the tmpfs must be full
MAX_UPLOADS = 200


def _chain(tag: str, links: int = CHAIN_LINKS, padding: int = 0) -> bytes:
    body = "".join(f'<link name="l{i}"/>' for i in range(links)) + "".join(
        f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
        f'<origin xyz="0 0 0.01" rpy="0 0.001 0"/><axis xyz="0 1 0"/>'
        f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>' for i in range(1, links))
    pad = f"<!-- {'p' * padding} -->" if padding else ""
    return f'<?xml version="1.0"?>\n<robot name="fault_{tag}">{pad}{body}</robot>\n'.encode()


def _upload(c: httpx.Client, body: bytes, **params) -> httpx.Response:
    return c.post("/models", content=body, headers={"Content-Type": "application/xml"}, params=params)


def _id(data: bytes) -> str:
    return "u-" + hashlib.sha256(data).hexdigest()[:16]


def _assert_problem(r: httpx.Response, status: int | None = None) -> dict:
    assert r.status_code != 500, r.text[:500]
    if status is not None:
        assert r.status_code == status, r.text[:500]
    assert r.headers["content-type"].startswith(PROBLEM), (r.status_code, r.headers["content-type"], r.text[:300])
    body = r.json()
    assert {"type", "title", "status", "detail"} <= body.keys() and body["status"] == r.status_code
    return body


def _leftovers(models: Path) -> list[str]:
    """Temporary files, and sidecars without their model."""
    names = set(os.listdir(models))
    return sorted(n for n in names if n.startswith(".tmp-") or (
        n.endswith(".meta.json") and not any(m.startswith(n[: -len(".meta.json")] + ".") and m != n for m in names)))


def _stored(c: httpx.Client) -> set[str]:
    r = c.get("/models")
    assert r.status_code == 200, r.text[:300]
    return {m["id"] for m in r.json() if m["source"] in ("upload", "dh", "poe", "axes")}


@pytest.fixture
def tmpfs(tmp_path):
    """``tmpfs(size)`` -> a fresh tmpfs mounted at ``tmp_path/data`` (unmounted afterwards); skips
    when not root or when the mount fails."""
    mounted: list[Path] = []

    def mount(size: str) -> Path:
        if os.geteuid() != 0:
            pytest.skip("mounting a tmpfs needs root")
        target = tmp_path / "data"
        target.mkdir()
        try:
            r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size},mode=0755", "tmpfs", str(target)],
                               capture_output=True, text=True, timeout=30)
        except (FileNotFoundError, subprocess.TimeoutExpired) as exc:
            pytest.skip(f"cannot mount a tmpfs: {exc}")
        if r.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs: {r.stderr.strip()}")
        mounted.append(target)
        return target

    yield mount
    for target in mounted:
        subprocess.run(["umount", "-l", str(target)], capture_output=True, timeout=30)


def _remount(target: Path, mode: str) -> None:
    subprocess.run(["mount", "-o", f"remount,{mode}", str(target)], check=True, capture_output=True, timeout=30)


# ---------------------------------------------------------------- a full disk
@pytest.mark.slow
def test_full_disk_refuses_with_507_keeps_every_acknowledged_model_and_recovers(tmpfs, tmp_path):
    data_dir = tmpfs(FULL_DISK_SIZE)
    models = data_dir / "models"
    acked: dict[str, bytes] = {}
    with LiveServer(data_dir, tmp_path / "server.log") as server, \
            httpx.Client(base_url=server.url, timeout=TIMEOUT) as c:
        refused = None
        for k in range(MAX_UPLOADS):
            body = _chain(f"fill_{k}")
            r = _upload(c, body)
            if r.status_code == 507:
                refused = (body, r)
                break
            assert r.status_code == 201, r.text[:300]
            acked[r.json()["id"]] = body
        assert refused is not None, f"the {FULL_DISK_SIZE} tmpfs took {MAX_UPLOADS} uploads"
        body, r = refused
        problem = _assert_problem(r, 507)
        assert problem["type"].endswith("storage-error") and "No space left on device" in problem["detail"]
        assert len(acked) >= 2
        # a second try of the same upload is refused the same way
        assert _upload(c, body).status_code == 507
        # every acknowledged model is there byte for byte, and nothing partial is left or listed
        assert _leftovers(models) == []
        assert _stored(c) == set(acked)
        assert c.get(f"/models/{_id(body)}").status_code == 404
        for mid, data in acked.items():
            assert (models / f"{mid}.urdf").read_bytes() == data
            r = c.get(f"/models/{mid}/urdf")
            assert r.status_code == 200 and r.content == data, mid
        some = next(iter(acked))
        assert c.post(f"/models/{some}/fk", json={"q": [0.1] * (CHAIN_LINKS - 1)}).status_code == 200
        # room again: two deletes, then the refused upload is taken
        for mid in list(acked)[:2]:
            assert c.delete(f"/models/{mid}").status_code == 204
            del acked[mid]
        r = _upload(c, body)
        assert r.status_code == 201, r.text[:300]
        acked[r.json()["id"]] = body
        assert _stored(c) == set(acked) and c.get(f"/models/{_id(body)}/urdf").content == body
        assert _leftovers(models) == []
        log = server.log()
    assert "Traceback" not in log


# ---------------------------------------------------------------- a read-only remount
@pytest.mark.slow
def test_read_only_remount_refuses_writes_with_507_and_keeps_serving_reads(tmpfs, tmp_path):
    data_dir = tmpfs("16m")
    kept, new = _chain("kept"), _chain("new")
    dh = {"convention": "standard", "joints": [{"type": "revolute", "a": 0.3, "alpha": 0, "d": 0.1, "theta": 0},
                                               {"type": "revolute", "a": 0.2, "alpha": 0, "d": 0, "theta": 0}]}
    with LiveServer(data_dir, tmp_path / "server.log") as server, \
            httpx.Client(base_url=server.url, timeout=TIMEOUT) as c:
        r = _upload(c, kept, name="kept")
        assert r.status_code == 201, r.text[:300]
        kept_id = r.json()["id"]
        _remount(data_dir, "ro")
        try:
            for r, action in ((_upload(c, new), "stored"),
                              (c.post("/models/dh", json=dh), "stored"),
                              (_upload(c, kept, name="renamed"), "renamed"),  # the same content, a new name
                              (c.delete(f"/models/{kept_id}"), "deleted")):
                problem = _assert_problem(r, 507)
                assert problem["type"].endswith("storage-error") and problem["title"] == "Data directory is read-only"
                assert "Read-only file system" in problem["detail"] and action in problem["detail"]
            # reads keep working: the model, its file, computations, the listing, health
            assert c.get("/health").status_code == 200
            info = c.get(f"/models/{kept_id}")
            assert info.status_code == 200 and info.json()["name"] == "kept"
            assert c.get(f"/models/{kept_id}/urdf").content == kept
            assert c.post(f"/models/{kept_id}/fk", json={"q": [0.2] * (CHAIN_LINKS - 1)}).status_code == 200
            assert _stored(c) == {kept_id}
            assert c.get(f"/models/{_id(new)}").status_code == 404
            # a server started on the read-only directory serves it too
            with LiveServer(data_dir, tmp_path / "server_ro.log") as ro, \
                    httpx.Client(base_url=ro.url, timeout=TIMEOUT) as c2:
                assert c2.get(f"/models/{kept_id}/urdf").content == kept
                _assert_problem(_upload(c2, new), 507)
        finally:
            _remount(data_dir, "rw")
        r = _upload(c, new)
        assert r.status_code == 201 and c.get(f"/models/{_id(new)}/urdf").content == new
        assert c.delete(f"/models/{kept_id}").status_code == 204
        assert _stored(c) == {_id(new)} and _leftovers(data_dir / "models") == []
        log = server.log()
    assert "Traceback" not in log


# ---------------------------------------------------------------- kill -9 during a large upload
def _tcp_queues(port_a: int, port_b: int) -> int | None:
    """The bytes queued on the loopback connection local ``port_a`` -> remote ``port_b`` (its send
    queue plus its receive queue, from /proc/net/tcp), or None when it is not listed."""
    with open("/proc/net/tcp") as fh:
        next(fh)
        for line in fh:
            fields = line.split()
            local, remote, queues = fields[1], fields[2], fields[4]
            if int(local.split(":")[1], 16) == port_a and int(remote.split(":")[1], 16) == port_b:
                tx, rx = (int(x, 16) for x in queues.split(":"))
                return tx + rx
    return None


@pytest.mark.slow
def test_kill_9_in_the_middle_of_a_large_upload_leaves_nothing_half_written(tmp_path):
    if not os.path.exists("/proc/net/tcp"):
        pytest.skip("needs /proc/net/tcp to see the upload received")
    data_dir = tmp_path / "data"
    body = _chain("large", links=50, padding=6 * 1024 * 1024)  # 6 MiB (under the 8 MiB of a URDF), in two halves
    half = len(body) // 2
    server = LiveServer(data_dir, tmp_path / "server.log").start()
    try:
        sock = socket.create_connection(("127.0.0.1", server.port), timeout=TIMEOUT)
        sock.sendall((f"POST /models HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/xml\r\n"
                      f"Content-Length: {len(body)}\r\n\r\n").encode() + body[:half])
        client_port = sock.getsockname()[1]
        sock.setblocking(False)
        # the first half is read by the server: nothing queued either way on the connection
        deadline = time.monotonic() + TIMEOUT
        while not (_tcp_queues(client_port, server.port) == 0 and _tcp_queues(server.port, client_port) == 0):
            assert time.monotonic() < deadline, "the server did not read the first half of the upload"
            assert server.proc.poll() is None, server.log()
            try:  # an answer before the whole body is a refusal: shown, not waited on
                early = sock.recv(4096, socket.MSG_PEEK)
            except BlockingIOError:
                early = b""
            assert not early, early
            time.sleep(0.01)
        server.kill(signal.SIGKILL)
        sock.close()
    finally:
        server.stop()
    models = data_dir / "models"
    assert sorted(os.listdir(models)) == []  # nothing written: not the model, a sidecar or a temporary file
    with LiveServer(data_dir, tmp_path / "server2.log") as server2, \
            httpx.Client(base_url=server2.url, timeout=TIMEOUT) as c:
        assert _stored(c) == set()
        assert c.get(f"/models/{_id(body)}").status_code == 404
        r = _upload(c, body)
        assert r.status_code == 201, r.text[:300]
        assert c.get(f"/models/{_id(body)}/urdf").content == body
    assert _leftovers(models) == []


# ---------------------------------------------------------------- stored files damaged while down
XACRO = b"""<?xml version="1.0"?>
<robot name="xarm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="l" value="0.25"/>
  <link name="a"/><link name="b"/>
  <joint name="j" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 ${l}"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""
DH = {"convention": "standard", "joints": [{"type": "revolute", "a": 0.4, "alpha": 0, "d": 0.1, "theta": 0}]}
DH_OTHER = {"convention": "standard", "joints": [{"type": "revolute", "a": 0.45, "alpha": 0, "d": 0.1, "theta": 0}]}


@pytest.mark.slow
def test_files_damaged_while_the_server_was_down(tmp_path):
    data_dir = tmp_path / "data"
    models = data_dir / "models"
    bodies = {tag: _chain(tag, links=20) for tag in ("intact", "truncated", "flipped", "emptied", "fifo",
                                                      "directory", "wrong_types", "sidecar_fifo")}
    with LiveServer(data_dir, tmp_path / "server.log") as server, \
            httpx.Client(base_url=server.url, timeout=TIMEOUT) as c:
        ids = {}
        for tag, body in bodies.items():
            r = _upload(c, body, name=tag)
            assert r.status_code == 201, r.text[:300]
            ids[tag] = r.json()["id"]
        for tag, req in (("dh_intact", c.post("/models/dh", json=DH)),
                         ("dh_damaged", c.post("/models/dh", json=DH_OTHER)),
                         ("xacro_intact", _upload(c, XACRO)),
                         ("xacro_no_sidecar", _upload(c, XACRO.replace(b"0.25", b"0.35")))):
            assert req.status_code == 201, (tag, req.text[:300])
            ids[tag] = req.json()["id"]
        expected = {tag: c.get(f"/models/{mid}/urdf").content for tag, mid in ids.items()}

    def path(tag: str) -> Path:
        (found,) = [p for p in models.iterdir() if p.name.startswith(ids[tag] + ".") and ".meta." not in p.name]
        return found

    data = path("truncated").read_bytes()
    path("truncated").write_bytes(data[: len(data) // 2])
    data = bytearray(path("flipped").read_bytes())
    data[len(data) // 2] ^= 0x04
    path("flipped").write_bytes(bytes(data))
    path("emptied").write_bytes(b"")
    p = path("fifo")
    p.unlink()
    os.mkfifo(p)
    p = path("directory")
    p.unlink()
    p.mkdir()
    (models / f"{ids['wrong_types']}.meta.json").write_text(json.dumps(
        {"name": 5, "created": 5, "source": ["upload"], "upload": {"args": 5}}))
    sidecar = models / f"{ids['sidecar_fifo']}.meta.json"
    sidecar.unlink()
    os.mkfifo(sidecar)
    p = path("dh_damaged")
    assert b"0.45" in p.read_bytes()
    p.write_bytes(p.read_bytes().replace(b"0.45", b"0.55"))
    (models / f"{ids['xacro_no_sidecar']}.meta.json").unlink()
    # temporary files of writes killed half-way: an old one is removed at start-up, a recent one (maybe
    # another process's write in progress) stays; neither is ever listed
    old, recent = models / ".tmp-killed.urdf", models / ".tmp-recent.urdf"
    for tmp in (old, recent):
        tmp.write_bytes(bodies["intact"][:1000])
    hours_ago = time.time() - 2 * 3600
    os.utime(old, (hours_ago, hours_ago))
    damaged = {"truncated", "flipped", "emptied", "fifo", "directory", "dh_damaged", "xacro_no_sidecar"}
    intact = set(ids) - damaged

    with LiveServer(data_dir, tmp_path / "server2.log") as server2, \
            httpx.Client(base_url=server2.url, timeout=TIMEOUT) as c:
        assert c.get("/health").status_code == 200
        assert not old.exists() and recent.exists()
        assert _stored(c) == {ids[t] for t in intact}
        for tag in intact:
            mid = ids[tag]
            info = c.get(f"/models/{mid}")
            assert info.status_code == 200, (tag, info.text[:300])
            assert c.get(f"/models/{mid}/urdf").content == expected[tag], tag
            dof = info.json()["dof"]
            r = c.post(f"/models/{mid}/fk", json={"q": [0.1] * dof})
            assert r.status_code == 200, (tag, r.text[:300])
        info = c.get(f"/models/{ids['wrong_types']}").json()
        assert info["name"] == "fault_wrong_types" and isinstance(info["created"], str)  # the sidecar's junk left out
        for tag in damaged:
            mid = ids[tag]
            for r in (c.get(f"/models/{mid}"), c.get(f"/models/{mid}/urdf"),
                      c.post(f"/models/{mid}/fk", json={"q": [0.1]})):
                problem = _assert_problem(r)
                assert 400 <= r.status_code < 500 and mid in problem["detail"], (tag, r.status_code, problem)
        # the damaged content can be uploaded again, and replaces the damaged file
        r = _upload(c, bodies["truncated"])
        assert r.status_code == 201 and c.get(f"/models/{ids['truncated']}/urdf").content == bodies["truncated"]
        log = server2.log()
    assert "Traceback" not in log
    for tag in damaged:
        assert any(ids[tag] in line and "WARNING" in line for line in log.splitlines()), (tag, log[-3000:])
