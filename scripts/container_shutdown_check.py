"""Graceful shutdown of the running container: ``podman stop`` while an IK batch is in flight.

Usage: ``python scripts/container_shutdown_check.py [CONTAINER] [URL]`` (default
``app-under-test`` at ``http://127.0.0.1:8000``; ``.ci/run`` calls it after the smoke test).
It sends 20,000 unreachable IK targets (a few seconds of work), stops the container one second
later, and checks that the batch still gets its 200 with every answer, that a new request is
refused meanwhile, and that the container exits 0 within the stop timeout (SIGTERM reached
uvicorn: exec-form CMD, ``KIN_SHUTDOWN_TIMEOUT`` under podman's and Docker's 10 s). Exit 0 when
all hold.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
import urllib.request

import numpy as np


def main(container: str = "app-under-test", url: str = "http://127.0.0.1:8000") -> int:
    targets = np.tile(np.eye(4), (20_000, 1, 1))
    targets[:, 0, 3] = 10.0  # out of reach: every target takes its full iterations
    body = json.dumps({"target": targets.tolist(), "link": "tool0", "restarts": 4}).encode()
    result: dict = {}

    def send() -> None:
        t = time.monotonic()
        request = urllib.request.Request(f"{url}/models/ur5/ik", data=body, headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=60) as answer:
                result.update(status=answer.status, answers=len(json.loads(answer.read())["q"]))
        except Exception as exc:  # noqa: BLE001 - reported below
            result.update(error=repr(exc))
        result["seconds"] = time.monotonic() - t

    worker = threading.Thread(target=send)
    worker.start()
    time.sleep(1.0)
    t0 = time.monotonic()
    stop = subprocess.Popen(["podman", "stop", "-t", "10", container], stdout=subprocess.DEVNULL)
    time.sleep(0.5)
    try:
        urllib.request.urlopen(f"{url}/health", timeout=2)
        refused = False
    except Exception:  # noqa: BLE001 - refused or reset: what shutdown should do
        refused = True
    stop.wait()
    stopped = time.monotonic() - t0
    worker.join()
    code = subprocess.run(["podman", "inspect", "-f", "{{.State.ExitCode}}", container],
                          capture_output=True, text=True).stdout.strip()
    ok = result.get("status") == 200 and result.get("answers") == len(targets) and refused and code == "0" \
        and stopped < 10 and result["seconds"] > 1.0
    print(f"shutdown: {'ok' if ok else 'FAILED'}: in-flight IK batch {result}; new request refused: {refused}; "
          f"stopped in {stopped:.1f} s, exit code {code}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
