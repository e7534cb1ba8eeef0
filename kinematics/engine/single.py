"""One configuration without call overhead: FK and Jacobians bound to a model and a link.

A batch call (``PoEModel.fk(Q)``) validates its arguments, looks up its plan and allocates
its scratch and result on every call: a few microseconds that dominate when the batch is one
configuration. :func:`fk_function` and :func:`jacobian_function` do that work once and
return a plain function of ``q`` (a float64 vector of ``dof`` values) that makes one call of a
compiled entry (:func:`~kinematics.engine.entries.fk_one`, :func:`~kinematics.engine.entries.jacobian_one`)
on two packed tables (every argument costs call time) whose tail is the scratch the frames are
written to. The entries compute the axis frames with scalar code on the flat tables that repeats
the batch kernels' arithmetic operation for operation (and the poses of ``_poses_row``, the
Jacobian columns of ``_jacobian_row``): the answer equals the batch row bit for bit
(``tests/kinematics/engine/test_single.py``). A batch of one row (``PoEModel.fk`` / ``jacobian``
with one configuration) runs the same entries.

What bounds it: the compiled work (~0.15 µs for a 6-joint arm's pose on an idle machine; it was
~0.5 µs when the entry built a dozen array views of its tables, each costing as much as a joint's
arithmetic), unboxing the four arrays into the compiled code (~0.2 µs: a float64 vector ``q``
skips numba's dispatcher, which typed each argument on every call, and calls the compiled entry's
wrapper directly; the entry itself refuses a ``q`` of the wrong length or stride, which then takes
the checked way), allocating the result (~0.1 µs) and the wrapper's own checks. The entries hold
the GIL (releasing and taking it back would cost more than the work), so every thread shares one
scratch. With ``out=`` the call goes through the dispatcher, which checks the given array's type.
``bench/single.py`` (``python -m bench.run_all --only single``) measures it against Pinocchio's
single call, with the spread over repeated runs.

>>> import numpy as np
>>> from kinematics import compile_model, default_catalogue
>>> ur5 = default_catalogue().get("ur5")
>>> fk1 = fk_function(compile_model(ur5), "tool0")
>>> q = np.array([0.1, -0.5, 0.8, 0.0, 1.2, -0.3])
>>> bool((fk1(q) == compile_model(ur5).fk(q[None], ["tool0"])[0, 0]).all())
True
>>> J1 = jacobian_function(compile_model(ur5), "tool0", "local")
>>> bool((J1(q) == compile_model(ur5).jacobian(q[None], "tool0", "local")[0]).all())
True
"""

from __future__ import annotations

import numpy as np

from ..spatial.reference import parse_reference
# the entries' binding helpers, private to the engine (entries.py and single.py are one feature split in two)
from .entries import _bind, _tables, fk_one, jacobian_one
from .plans import _REFERENCE_CODES, with_tool


def _compiled(model):
    """A :class:`~kinematics.engine.poe.PoEModel` as it is, or the compiled form of a RobotModel."""
    if hasattr(model, "kernel"):
        return model
    from .poe import require_one_dof

    return require_one_dof(getattr(model, "model", model), "single-configuration entries (fk_function, "
                           "jacobian_function)")


def fk_function(poe, links, tool: np.ndarray | None = None):
    """``f(q, out=None)``: the pose ``T_world_link`` (4, 4) of ``links`` (a link name), or the poses
    (L, 4, 4) of a list of links, for one configuration ``q`` (a float64 vector in
    ``joint_names`` order). ``tool``: ``T_link_tool`` (4, 4) applied to every link. Thread-safe
    (the compiled entry holds the GIL); ``out`` receives the result when given."""
    poe = _compiled(poe)
    kernel = poe.kernel
    one = isinstance(links, str)
    idx = poe.link_indices([links] if one else list(links))
    plan = kernel.plan(idx)
    D = with_tool(plan.pose, None if tool is None else np.asarray(tool, dtype=np.float64))
    dof = poe.dof
    itab, ftab = _tables(kernel, plan.order, 0, plan.lj, D)
    fk = _bind(fk_one, itab, ftab, (4, 4) if one else (len(idx), 4, 4), dof)
    fk.__doc__ = f"Pose(s) {(4, 4) if one else (len(idx), 4, 4)} of {links!r} of model {poe.model.name!r} for one q ({dof} values)."
    return fk


def jacobian_function(poe, link: str, reference: str = "world", tool: np.ndarray | None = None):
    """``f(q, out=None)``: the Jacobian (6, dof) of ``link`` in ``reference`` (linear rows first)
    for one configuration ``q``; as :func:`fk_function` otherwise."""
    poe = _compiled(poe)

    kernel = poe.kernel
    ref = _REFERENCE_CODES[parse_reference(reference)]
    li = int(poe.link_indices([link])[0])
    path, D = kernel.path_plan(li)
    D = with_tool(D, None if tool is None else np.asarray(tool, dtype=np.float64))
    dof = poe.dof
    itab, ftab = _tables(kernel, path, ref, [], D)
    jacobian = _bind(jacobian_one, itab, ftab, (6, dof), dof)
    jacobian.__doc__ = f"Jacobian (6, {dof}) of {link!r} ({reference}) of model {poe.model.name!r} for one q."
    return jacobian
