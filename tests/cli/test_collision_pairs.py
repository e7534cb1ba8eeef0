"""--allow / --forbid of kinematics collision, collision-matrix and the collision-avoiding commands."""

from __future__ import annotations

import csv
from contextlib import nullcontext
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from kinematics.algorithms import self_collision
from kinematics.cli import main

#: (base_link, upper_arm_link) collides here (MoveIt's UR5 SRDF disables the pair as "never")
BASE_UPPER_ARM = [-3.58, 1.75, 1.92, 5.83, -4.39, -0.22]
FOLDED = [0, -1.0, 2.9, 0, 0, 0]


def _pairs(path):
    return [set(r["pairs"].split(";")) - {""} for r in csv.DictReader(path.open())]


def test_allow_and_forbid(tmp_path, catalogue, capsys):
    src = tmp_path / "q.csv"
    src.write_text("\n".join(",".join(map(str, q)) for q in (BASE_UPPER_ARM, FOLDED)) + "\n")
    out = tmp_path / "r.csv"
    assert main(["collision", "--model", "ur5", str(src), "-n", "300", "-o", str(out)]) == 0
    plain = _pairs(out)
    assert "base_link|upper_arm_link" in plain[0]
    assert main(["collision", "--model", "ur5", str(src), "-n", "300", "-o", str(out),
                 "--allow", "upper_arm_link,base_link", "--forbid", "forearm_link,wrist_1_link"]) == 0
    changed = _pairs(out)
    lib = self_collision.check(catalogue.get("ur5"), np.array([BASE_UPPER_ARM, FOLDED]),
                               pairs=[("forearm_link", "wrist_1_link")])  # adjacent: touching at the joint
    assert changed[0] == (plain[0] - {"base_link|upper_arm_link"}) | (
        {"forearm_link|wrist_1_link"} if lib.colliding[0] else set())
    assert ("forearm_link|wrist_1_link" in changed[1]) == bool(lib.colliding[1])
    srdf = tmp_path / "ur5.srdf"
    assert main(["collision-matrix", "--model", "ur5", "-n", "300", "-o", str(srdf),
                 "--allow", "base_link,upper_arm_link", "--forbid", "forearm_link,wrist_1_link"]) == 0
    doc = ET.parse(srdf)
    assert ("base_link", "upper_arm_link", "User") in [(e.get("link1"), e.get("link2"), e.get("reason"))
                                                       for e in doc.iter("disable_collisions")]
    assert [(e.get("link1"), e.get("link2")) for e in doc.iter("enable_collisions")] == [("forearm_link", "wrist_1_link")]
    capsys.readouterr()


@pytest.mark.parametrize("extra, code, said", [
    (["--allow", "base_link"], 2, "not a link pair"),
    (["--allow", "base_link,nope_link"], 2, "nope_link"),
    (["--allow", "base_link,ee_link", "--forbid", "ee_link,base_link"], 2, "both allowed and forbidden"),
])
def test_bad_pairs_are_usage_errors(tmp_path, capsys, extra, code, said):
    src = tmp_path / "q.csv"
    src.write_text(",".join(map(str, FOLDED)) + "\n")
    with pytest.raises(SystemExit) if "not a link pair" in said else nullcontext():  # argparse exits 2
        assert main(["collision", "--model", "ur5", str(src), "-n", "50", *extra]) == code
    assert said in capsys.readouterr().err



def test_ik_all_avoid_collisions_takes_the_pairs(tmp_path, catalogue, capsys):
    ur5 = catalogue.get("ur5")
    Q = ur5.sample_configurations(6, np.random.default_rng(0))
    from kinematics import compile_model, usecases

    np.save(tmp_path / "T.npy", compile_model(ur5).fk(Q, ["tool0"])[:, 0])
    strict = usecases.ik(ur5, compile_model(ur5).fk(Q, ["tool0"])[:, 0], link="tool0", solutions="all",
                         avoid_collisions=True, collision_samples=300)
    assert strict.colliding.sum() > 0
    allow = [arg for a, b in self_collision.matrix(ur5, 300).enabled() for arg in ("--allow", f"{a},{b}")]
    out = tmp_path / "free.csv"
    main(["ik", "--model", "ur5", "--link", "tool0", "--all", "--avoid-collisions", "--collision-samples", "300",
          str(tmp_path / "T.npy"), "-o", str(out), *allow])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert len(list(csv.reader(open(out)))) - 1 == strict.count.sum() + strict.colliding.sum()
    assert main(["ik", "--model", "ur5", "--link", "tool0", "--all", "--avoid-collisions", "--collision-samples",
                 "300", str(tmp_path / "T.npy"), "-o", str(out), "--allow", "nope_link,base_link"]) == 2
    assert "nope_link" in capsys.readouterr().err
