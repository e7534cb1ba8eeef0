"""The catalogue lists only what loads: the file without a robot name is left out, with its reason."""

import pytest

from kinematics.errors import URDFError
from kinematics.io.catalogue import UNLOADABLE, Catalogue, example_robot_data_dir
from kinematics.io.urdf import load_urdf

ROBOTS = example_robot_data_dir()
pytestmark = pytest.mark.skipif(ROBOTS is None, reason="example-robot-data is not installed")


def test_the_unnamed_ur3_is_left_out_and_says_why():
    cat = Catalogue(robots_dir=ROBOTS)
    assert "ur3_unnamed" not in cat and "ur3" in cat
    assert set(cat.skipped) == set(UNLOADABLE) and "no name" in cat.skipped["ur_description/urdf/ur3.urdf"]
    assert not any(str(e.path).endswith("ur_description/urdf/ur3.urdf") for e in cat.entries.values())


def test_each_left_out_file_is_really_refused():
    for rel in UNLOADABLE:
        with pytest.raises(URDFError, match="name"):
            load_urdf(ROBOTS / rel)


def test_the_ur_arms_of_the_listing_load():
    cat = Catalogue(robots_dir=ROBOTS)
    for model_id in [i for i in cat.ids() if i.startswith("ur")]:
        assert cat.get(model_id).dof >= 6
