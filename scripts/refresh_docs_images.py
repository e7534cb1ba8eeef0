"""Refresh the viewer screenshots the documentation shows (``make docs-images``).

The browser tests (``tests/app/test_viewer*.py``, headless Chromium: ``apt-get install chromium
chromium-driver``) save their screenshots in ``tests/artifacts/`` only, so that ``make test`` never
rewrites a tracked file. This script runs the tests that take the documentation's pictures and
copies each shot over its picture in ``docs/``: run it when the viewer's look changed, and commit
the pictures it wrote.

    python scripts/refresh_docs_images.py          # from the repository root
    python scripts/refresh_docs_images.py viewer_redundancy.png   # only these pictures
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
ARTIFACTS = REPO / "tests" / "artifacts"
#: the test that takes each picture: test id, its screenshot in tests/artifacts, the picture in docs/
PICTURES = (
    ("tests/app/test_viewer.py::test_ik_target_solves_a_reachable_target_and_reports_an_unreachable_one",
     "viewer_ik_solved.png", "viewer_ik.png"),
    ("tests/app/test_viewer_ghosts.py::test_ghosts_are_every_solution_and_a_click_takes_one",
     "viewer_ik_ghosts.png", "viewer_ik_ghosts.png"),
    ("tests/app/test_viewer_ghosts.py::test_the_calibration_tab_draws_a_bar_per_measurement",
     "viewer_calibration.png", "viewer_calibration.png"),
    ("tests/app/test_viewer_trajectory.py::test_a_planned_path_is_timed_played_in_time_and_charted",
     "viewer_trajectory.png", "viewer_trajectory.png"),
    ("tests/app/test_viewer_redundancy.py::test_the_slider_sweeps_the_panda_along_its_self_motion",
     "viewer_redundancy.png", "viewer_redundancy.png"),
)


def main(only: list[str]) -> int:
    unknown = sorted(set(only) - {picture for _, _, picture in PICTURES})
    if unknown:
        print(f"refresh_docs_images: no picture {', '.join(unknown)} (the pictures: "
              f"{', '.join(picture for _, _, picture in PICTURES)})", file=sys.stderr)
        return 2
    pictures = [p for p in PICTURES if not only or p[2] in only]
    for _, shot, _ in pictures:
        (ARTIFACTS / shot).unlink(missing_ok=True)
    tests = [test for test, _, _ in pictures]
    # -rs names a skipped test (no Chromium); a skip leaves its shot missing, reported below
    code = subprocess.call([sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:randomly", "-rs", *tests],
                           cwd=REPO)
    if code != 0:
        print(f"refresh_docs_images: the tests failed (exit {code}); docs/ left as it was", file=sys.stderr)
        return code
    missing = [shot for _, shot, _ in pictures if not (ARTIFACTS / shot).exists()]
    if missing:
        print(f"refresh_docs_images: no screenshot {', '.join(missing)} (were the browser tests skipped? "
              "apt-get install chromium chromium-driver); docs/ left as it was", file=sys.stderr)
        return 1
    for _, shot, picture in pictures:
        (REPO / "docs" / picture).write_bytes((ARTIFACTS / shot).read_bytes())
        print(f"docs/{picture} <- tests/artifacts/{shot}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
