"""kinematics collision and kinematics collision-matrix."""

from __future__ import annotations

import csv
import json
import xml.etree.ElementTree as ET

import numpy as np

from kinematics.algorithms import self_collision
from kinematics.cli import main

FOLDED = [0, -1.0, 2.9, 0, 0, 0]
READY = [0, -1.57, 0, -1.57, 0, 0]


def test_collision_report(tmp_path, catalogue, capsys):
    src = tmp_path / "q.csv"
    src.write_text("\n".join(",".join(map(str, q)) for q in (READY, FOLDED)) + "\n")
    out = tmp_path / "report.csv"
    assert main(["collision", "--model", "ur5", str(src), "--distance", "-n", "300", "-o", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    lib = self_collision.check(catalogue.get("ur5"), np.array([READY, FOLDED], dtype=float), samples=300,
                               distance=True)
    assert [int(r["colliding"]) for r in rows] == [0, 1]
    assert rows[1]["pairs"].split(";") == [f"{a}|{b}" for a, b in lib.pairs[1]]
    assert float(rows[0]["min_distance"]) == lib.min_distance[0]
    assert "1 of 2 configurations in collision" in capsys.readouterr().err
    assert main(["collision", "--model", "ur5", str(src), "--per-pair", "-n", "300", "-o", str(out)]) == 0
    rows = list(csv.reader(out.open()))
    assert rows[0][:2] == ["row", "colliding"] and sum(map(int, rows[2][2:])) == len(lib.pairs[1])


def test_collision_matrix_srdf_and_json(tmp_path, capsys):
    srdf = tmp_path / "panda.srdf"
    assert main(["collision-matrix", "--model", "panda", "-n", "300", "-o", str(srdf), "--cache", str(tmp_path)]) == 0
    rows = [(e.get("link1"), e.get("link2"), e.get("reason")) for e in ET.parse(srdf).iter("disable_collisions")]
    assert ("panda_link0", "panda_link1", "Adjacent") in rows
    assert list(tmp_path.glob("collision-matrix-*.json"))  # cached
    js = tmp_path / "panda.json"
    assert main(["collision-matrix", "--model", "panda", "-n", "300", "-o", str(js), "--cache", str(tmp_path)]) == 0
    doc = json.loads(js.read_text())
    assert doc["samples"] == 300 and len(doc["disabled"]) == len(rows)
    assert "pairs disabled" in capsys.readouterr().err


def test_bad_input_is_a_usage_error(tmp_path):
    src = tmp_path / "q.csv"
    src.write_text("1,2\n")
    assert main(["collision", "--model", "ur5", str(src), "-n", "50"]) == 2
    assert main(["collision-matrix", "--model", "ur5", "-n", "0"]) == 2
    assert main(["collision-matrix", "--model", "nope"]) == 3
