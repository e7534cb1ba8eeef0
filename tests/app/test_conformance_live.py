"""Schemathesis with **every check**, against a real ``uvicorn app.main:app``, unkeyed and keyed.

The service is tested as a client finds it: a live server (``tests.live.LiveServer``: a
subprocess on a free port, a fresh ``KIN_DATA_DIR``), its own ``/openapi.json``, and the
schemathesis command line (``schemathesis run --checks all``: examples, coverage, fuzzing and
stateful phases; positive and negative data). Run twice:

* **unkeyed** (no ``KIN_API_KEY``): the document declares no security at all, and nothing may
  answer 401/403 for a missing key (ST401 ``ignored_auth`` would notice);
* **keyed** (``KIN_API_KEY`` set, the key sent with ``-H X-API-Key``): writes declare and need
  the key; schemathesis also drops it to check that they are refused without it.

Every failure fails the test, with the schemathesis report in the message. Four checks are
replaced, not weakened blindly (``tests/app/schemathesis_hooks.py`` says why, in full):

* ``positive_data_acceptance`` (ST202) by ``positive_data_acceptance_semantic``, which accepts a
  413/422 refusal of a schema-valid request only when its problem type is one of the model- or
  content-dependent ones no OpenAPI document can express (a ``q`` of the wrong length for *that*
  model, an XML string that is not a robot, a budget over the server's settings);
* ``ensure_resource_availability`` (ST302) by ``resource_availability_of_models``, which does not
  count a 404 ``unknown-link`` naming the just-created model (the model was found; a link named
  in the body is not one of its links);
* ``negative_data_rejection`` (ST201) by ``negative_data_rejection_of_limits``, which takes the 413
  ``workspace-samples-too-large`` / ``batch-too-large`` answer to a request over a limit the document
  states from the settings (``maximum``, ``maxItems``) as the refusal it is;
* ``not_a_server_error`` (ST101) by ``not_a_server_error_but_time_budgets``, which takes the documented
  503 ``time-budget-exceeded`` (a closed form over its time limit) as the answer it is.

Everything else they refuse is a failure as before.

Bounded: ``MAX_EXAMPLES`` cases per operation and phase, a fixed seed (``KIN_CONFORMANCE_SEED``
to explore another; ``KIN_CONFORMANCE_EXAMPLES`` for more cases), one schemathesis worker, no wall-clock limit
on the run (it is bounded by its cases; each request by ``--request-timeout``); about 25 s per run on
2 idle cores, several minutes on a loaded machine.
Reproduce by hand (with a server on port 8000)::

    SCHEMATHESIS_HOOKS=tests.app.schemathesis_hooks schemathesis run http://127.0.0.1:8000/openapi.json \\
        --checks all --exclude-checks positive_data_acceptance,ensure_resource_availability,negative_data_rejection,\\
        not_a_server_error -n 10 --seed 20261201
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from tests.live import LiveServer
from tests.paths import REPO

pytestmark = pytest.mark.slow

#: cases per operation and phase (KIN_CONFORMANCE_EXAMPLES explores more, e.g. 100 before a release)
MAX_EXAMPLES = int(os.environ.get("KIN_CONFORMANCE_EXAMPLES", "10"))
SEED = int(os.environ.get("KIN_CONFORMANCE_SEED", "20261201"))
API_KEY = "conformance-key"
#: the built-in check replaced by the hooks module's stricter-where-it-can version (see above)
REPLACED_CHECKS = ("positive_data_acceptance", "ensure_resource_availability", "negative_data_rejection",
                   "not_a_server_error")


def run_schemathesis(url: str, report_dir, headers: dict[str, str] | None = None) -> tuple[dict, str]:
    """``schemathesis run --checks all`` against ``url``; (the JSON report, the console output)."""
    report = report_dir / "report.json"
    cmd = [sys.executable, "-m", "schemathesis.cli", "run", f"{url}/openapi.json",
           "--checks", "all", "--exclude-checks", ",".join(REPLACED_CHECKS),
           "--max-examples", str(MAX_EXAMPLES), "--seed", str(SEED), "--workers", "1",
           "--generation-database", "none", "--no-color", "--request-timeout", "60",
           # a response may take as long as the request timeout: a wall-clock bound of its own (the
           # default 10 s) fails on a loaded machine, and speed is measured in bench/, not here
           "--max-response-time", "60",
           "--report", "json", "--report-json-path", str(report)]
    for name, value in (headers or {}).items():
        cmd += ["-H", f"{name}: {value}"]
    env = {**os.environ, "PYTHONPATH": str(REPO), "SCHEMATHESIS_HOOKS": "tests.app.schemathesis_hooks"}
    # no wall-clock limit of its own (600 s ran out on a loaded machine): the run is bounded by its cases
    # (MAX_EXAMPLES per operation and phase) and each request by --request-timeout
    proc = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True)
    output = proc.stdout + proc.stderr
    assert report.exists(), f"schemathesis wrote no report (exit {proc.returncode}):\n{output}"
    return json.loads(report.read_text()), output


@pytest.mark.parametrize("keyed", [False, True], ids=["unkeyed", "keyed"])
def test_schemathesis_all_checks_against_a_live_server(tmp_path, keyed):
    data = tmp_path / "data"
    data.mkdir()
    # closed forms give up sooner (503 time-budget-exceeded, documented); the allowed-collision matrix of a large
    # robot samples fewer configurations (a first GET of PR2's at the default 10,000 takes ~20 s on a busy machine,
    # over schemathesis's 10 s response-time check; it is computed once and cached)
    env = {"KIN_SYMBOLIC_TIMEOUT": "5", "KIN_COLLISION_SAMPLES": "500"}
    if keyed:
        env["KIN_API_KEY"] = API_KEY
    with LiveServer(data, tmp_path / "uvicorn.log", env=env) as live:
        doc = __import__("httpx").get(live.url + "/openapi.json").json()
        assert ("securitySchemes" in doc.get("components", {})) == keyed
        report, output = run_schemathesis(live.url, tmp_path, {"X-API-Key": API_KEY} if keyed else None)
    cases = report["test_cases"]
    print(f"schemathesis ({'keyed' if keyed else 'unkeyed'}): {cases['generated']} cases, "
          f"{report['operations']['tested']} operations, {report['running_time']:.1f} s")
    tail = output[-20000:]
    assert report["operations"]["tested"] == report["operations"]["total"] > 20, tail
    assert report["operations"]["errored"] == 0 and not report["errors"], tail
    assert cases["generated"] > 500, tail
    assert not report["failures"] and cases["with_failures"] == 0, tail
    assert report["exit_code"] == 0, tail
