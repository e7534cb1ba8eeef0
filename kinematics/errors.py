"""Exceptions of the kinematics library.

Every error the library raises on bad input derives from :class:`KinematicsError`, and its
message names the offending element (joint, link, field, row). The web layer maps these
classes to HTTP problem-details answers; nothing else in the library knows about HTTP.
"""

from __future__ import annotations


class KinematicsError(Exception):
    """Base class of every error this library raises on bad input."""


class URDFError(KinematicsError):
    """A URDF document that is malformed, hostile, or describes an unsupported model."""


class UnsupportedJointError(URDFError):
    """A joint the product does not support (a ball joint; a planar joint whose plane normal is not
    its frame's z axis; a mimic of a floating or planar joint)."""


class ModelTooLargeError(URDFError):
    """A URDF with more links or joints than the configured limit."""


class DHError(KinematicsError):
    """A Denavit-Hartenberg table that is malformed or inconsistent."""


class NoDHFormError(KinematicsError):
    """A model that has no Denavit-Hartenberg form (a tree without a tip, a mimic joint, ...)."""


class JointValueError(KinematicsError):
    """Joint values of the wrong shape, with non-finite entries, or with unknown names."""


class ConfigurationNormError(JointValueError):
    """A floating joint's quaternion, or a planar joint's ``(cos, sin)``, that is not of unit norm
    (``joint`` names the joint); requests may ask to ``normalize`` instead."""

    def __init__(self, message: str, *, joint: str):
        super().__init__(message)
        self.joint = joint


class UnknownLinkError(KinematicsError):
    """A link name that the model does not have."""


class UnknownMeshError(KinematicsError):
    """A visual mesh index that the model does not serve (out of range, not a number, or a mesh
    that is never read: a plain upload's)."""


class UnknownModelError(KinematicsError):
    """A model id that the catalogue does not have."""


class LimitError(KinematicsError):
    """Joint values outside the joint limits, when the caller asked for them to be refused."""


class ReferenceUnavailableError(KinematicsError):
    """The reference implementation (Pinocchio) cannot load or evaluate this model."""


class PoseError(KinematicsError):
    """A pose given as data (an IK target, a tool offset) that is malformed or not rigid."""


class BasePoseError(PoseError):
    """A base pose (the root link's pose in the world) that is malformed or not rigid."""


class BudgetError(KinematicsError):
    """A request over one of the caller's budgets (:class:`kinematics.usecases.Budget`).

    ``budget`` names which (``batch``: configurations; ``verify``: configurations compared
    with the reference; ``result``: numbers in the answer), ``field`` the part of the request
    and ``limit`` the bound.
    """

    def __init__(self, message: str, *, budget: str, field: str, limit: int):
        super().__init__(message)
        self.budget = budget
        self.field = field
        self.limit = limit


class CancelledError(KinematicsError):
    """A computation stopped before its end because its caller cancelled it (a client that went
    away; :class:`kinematics.usecases.Cancellation`)."""


class TimeBudgetError(CancelledError):
    """A computation stopped because it took longer than its time budget: ``limit`` seconds, from
    the setting named by ``setting`` (:class:`kinematics.usecases.Cancellation`)."""

    def __init__(self, message: str, *, setting: str, limit: float):
        super().__init__(message)
        self.setting = setting
        self.limit = limit


class PoEError(KinematicsError):
    """A product-of-exponentials description (``M``, screws ``S_i`` or ``B_i``) that is malformed."""


class AxesError(KinematicsError):
    """A zero-configuration axes description (``h_i``, ``p_{i-1,i}``, ``p_nT``) that is malformed."""


class SymbolicError(KinematicsError):
    """A closed-form (symbolic) request that cannot be served: a bad expression or parameter
    name, a chain without moving joints, an unsupported task representation."""


class SymbolicTimeoutError(TimeBudgetError, SymbolicError):
    """The closed forms took longer than their time limit, ``timeout`` seconds: a time budget like any
    other (``limit``; ``setting`` names where the limit came from, the ``timeout`` argument unless the
    caller says which setting it is)."""

    def __init__(self, message: str, *, timeout: float, setting: str = "timeout"):
        super().__init__(message, setting=setting, limit=timeout)
        self.timeout = timeout


class LockedJointError(KinematicsError):
    """A ``locked`` entry of an IK request names no joint of the model, or a value that is not a
    number or is outside the joint's limits (``joint`` names it)."""

    def __init__(self, message: str, *, joint: str):
        super().__init__(message)
        self.joint = joint


class TaskError(KinematicsError):
    """A task-space representation that is unknown or malformed (``representation``, ``components``)."""


class RepresentationSingularityError(TaskError):
    """The orientation representation is singular at a configuration: ``E(phi)`` is not invertible
    (Euler angles at their gimbal lock, a rotation vector at a half turn)."""


class XacroError(URDFError):
    """A xacro document that cannot be expanded: malformed, a missing include, package or
    argument, or a file or expression the sandbox refused (the message names it)."""


class ExpansionLimitError(XacroError):
    """A xacro expansion over one of its limits (CPU time, memory, output size, macro calls)."""


class ArchiveError(URDFError):
    """A description archive (``.zip``, ``.tar.gz``) that is malformed or hostile: a path that
    leaves the archive, a link, a device, or no description to load (the message names the member)."""


class ArchiveTooLargeError(ArchiveError):
    """A description archive over its size limits (uncompressed bytes, members): a zip bomb."""


class MJCFError(URDFError):
    """An MJCF (MuJoCo) document that is malformed, names files, or uses what the product does not read."""


class DescriptionFormatError(URDFError):
    """A body that is none of the descriptions the product reads (URDF, xacro, MJCF, zip or gzip archive)."""


class CalibrationError(KinematicsError):
    """Measurements a calibration cannot use: too few for the parameters they should determine,
    non-finite values, a configuration of the wrong length, a set that determines nothing (all
    configurations equal, collinear points); ``field`` names the part of the request."""

    def __init__(self, message: str, *, field: str = "measurements"):
        super().__init__(message)
        self.field = field


#: the PyPI distribution of this library (what ``pip install`` names)
DISTRIBUTION = "kinematics-service"


class MissingExtraError(KinematicsError, ImportError):
    """A feature whose optional dependencies are not installed: ``extra`` names the extra of
    ``pyproject.toml`` that brings them, and the message the ``pip install`` to run. Also an
    :class:`ImportError`, so code that treats a missing module as absent still does.

    >>> str(MissingExtraError.of("verify", "verification against Pinocchio", "pinocchio"))
    "verification against Pinocchio: the optional dependency 'pinocchio' is not installed; run pip install 'kinematics-service[verify]'"
    """

    def __init__(self, message: str, *, extra: str, module: str | None = None):
        super().__init__(message)
        self.extra = extra
        self.module = module

    @classmethod
    def of(cls, extra: str, feature: str, module: str) -> "MissingExtraError":
        """The error for ``feature``, which imports ``module`` from the extra ``extra``."""
        return cls(f"{feature}: the optional dependency {module!r} is not installed; run {install_command(extra)}",
                   extra=extra, module=module)


def install_command(extra: str) -> str:
    """The command that installs an extra: ``pip install 'kinematics-service[EXTRA]'``."""
    return f"pip install '{DISTRIBUTION}[{extra}]'"


def did_you_mean(name: object, valid, what: str = "names", limit: int = 10) -> str:
    """A suffix for "unknown name" messages: the closest valid names and a truncated list of them.

    >>> did_you_mean("elbo", ["shoulder", "elbow", "wrist"])
    "; did you mean 'elbow'? valid names: shoulder, elbow, wrist"
    """
    import difflib

    valid = [str(v) for v in valid]
    if not valid:
        return ""
    close = difflib.get_close_matches(str(name), valid, n=3, cutoff=0.6)
    out = ""
    if close:
        out = "; did you mean " + " or ".join(repr(c) for c in close) + "?"
    else:
        out = ";"
    shown = ", ".join(valid[:limit])
    more = f", ... ({len(valid)} in all)" if len(valid) > limit else ""
    return f"{out} valid {what}: {shown}{more}"


class CollisionError(KinematicsError):
    """A self-collision request the model cannot answer: a pair naming a link without collision
    geometry or one link twice, a bad margin, a mesh that cannot be built."""
