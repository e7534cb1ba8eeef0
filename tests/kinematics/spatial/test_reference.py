"""The Reference enum: its values, their order, and how unknown names are refused."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import KinematicsError, compile_model, default_catalogue
from kinematics.spatial.reference import REFERENCES, Reference


def test_reference_values_are_pinocchio_names():
    assert Reference.WORLD == "world"
    assert Reference.LOCAL == "local"
    assert Reference.LOCAL_WORLD_ALIGNED == "local_world_aligned"
    assert [r.value for r in Reference] == ["world", "local", "local_world_aligned"]
    assert str(Reference.LOCAL_WORLD_ALIGNED) == "local_world_aligned"
    assert f"{Reference.WORLD}" == "world"


def test_references_order():
    assert REFERENCES == ("world", "local", "local_world_aligned")
    assert all(type(r) is str for r in REFERENCES)


def test_reference_from_string():
    assert Reference("local") is Reference.LOCAL
    with pytest.raises(ValueError):
        Reference("bogus")
    with pytest.raises(ValueError):
        Reference("World")


def test_engine_refuses_unknown_reference_naming_the_expected_values():
    model = default_catalogue().get("ur5")
    poe = compile_model(model)
    Q = np.zeros((1, model.dof))
    with pytest.raises(KinematicsError) as err:
        poe.jacobian(Q, "tool0", "bogus")
    message = str(err.value)
    assert "bogus" in message
    for name in REFERENCES:
        assert name in message
    with pytest.raises(KinematicsError, match="bogus"):
        poe.jacobian_reference(Q, "tool0", "bogus")


@pytest.mark.parametrize("reference", list(Reference) + list(REFERENCES))
def test_engine_accepts_enum_members_and_strings_alike(reference):
    model = default_catalogue().get("ur5")
    Q = np.full((2, model.dof), 0.3)
    J = compile_model(model).jacobian(Q, "tool0", reference)
    np.testing.assert_array_equal(J, compile_model(model).jacobian(Q, "tool0", Reference(reference).value))
