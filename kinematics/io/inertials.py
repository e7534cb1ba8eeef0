"""The masses and centres of mass of a model's links, read from its URDF's ``<inertial>`` elements.

The kinematics never use them (:func:`kinematics.io.urdf.parse_urdf` leaves them out); a
calibration's gravity-compliance term does (the torque gravity puts on each joint,
:mod:`kinematics.algorithms.calibration.compliance`).
"""

from __future__ import annotations

import numpy as np

from ..errors import URDFError
from ..tolerances import MAX_ABS_COORDINATE
# the URDF reader's number parsing, private to io: the inertials are read from the same attributes, with its checks
from .urdf import _number, _numbers, read_xml


def link_inertials(urdf: str | bytes) -> dict[str, tuple[float, np.ndarray]]:
    """``{link: (mass kg, centre of mass (3,) in the link frame, m)}`` of every link whose
    ``<inertial>`` has a ``<mass>`` (a link without one weighs nothing).

    >>> doc = '<robot name="r"><link name="a"><inertial><origin xyz="0 0 0.1"/><mass value="2"/></inertial></link></robot>'
    >>> m, c = link_inertials(doc)["a"]; (m, c.tolist())
    (2.0, [0.0, 0.0, 0.1])
    """
    root = read_xml(urdf.encode() if isinstance(urdf, str) else urdf)
    out: dict[str, tuple[float, np.ndarray]] = {}
    for link in root.findall("link"):
        name = link.get("name")
        inertial = link.find("inertial")
        mass_el = None if inertial is None else inertial.find("mass")
        if mass_el is None:
            continue
        mass = _number(mass_el.get("value"), f"link {name!r} <mass>", 0.0, 1e6)
        if mass < 0:
            raise URDFError(f"link {name!r} <mass>: a mass cannot be negative ({mass:g})")
        origin = inertial.find("origin")
        xyz = _numbers(None if origin is None else origin.get("xyz"), 3, f"link {name!r} <inertial> <origin xyz>",
                       "0 0 0", MAX_ABS_COORDINATE)
        out[name] = (float(mass), np.array(xyz, dtype=float))
    return out
