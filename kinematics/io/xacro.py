"""xacro -> URDF -> :class:`~kinematics.model.RobotModel`, expanded in a sandboxed process.

xacro evaluates Python expressions (``${...}``) and reads files (``<xacro:include>``,
``$(find pkg)``, ``xacro.load_yaml``), so a xacro document is never expanded in this
process. :func:`expand` runs the ``xacro`` package in a separate Python process
(:mod:`kinematics.io.xacro_sandbox`) that lowers its own CPU time, memory and output-size
limits, moves into the description's directory, resolves ``$(find pkg)`` only to the
packages found there, refuses expressions that reach for Python's internals, and refuses --
through an audit hook it cannot remove -- every file outside the allowed directories, every
write, socket, subprocess and new import. Its environment is empty. The URDF it returns is
then read by :func:`kinematics.io.urdf.parse_urdf` like any other.

* :func:`parse_xacro` -- xacro *text* (an upload): the sandbox directory is a new temporary
  directory holding only that text, so an include or ``$(find)`` can reach nothing else;
* :func:`load_xacro` -- a xacro *file* of the user's (CLI): readable are its directory and
  the ``package_paths`` given, whose packages (``package.xml``, else the directory name)
  ``$(find)`` resolves;
* :func:`expand` -- the common step, for :mod:`kinematics.io.archive` too.

Arguments (``<xacro:arg>``) are given as ``args={"name": "value"}``.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Iterable, Mapping

from defusedxml import DefusedXmlException
from defusedxml.ElementTree import fromstring as safe_fromstring

from ..errors import ExpansionLimitError, MissingExtraError, URDFError, XacroError
from ..model.robot import RobotModel
from .urdf import DEFAULT_MAX_LINKS, parse_urdf

#: the worker script (run as a file, never imported)
WORKER = Path(__file__).with_name("xacro_sandbox.py")
#: file name of an uploaded xacro text inside its sandbox directory
UPLOAD_NAME = "robot.urdf.xacro"
#: what a package name or xacro argument name may look like
_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.\-]{0,127}$")
#: deepest directory level searched for packages under a package path
PACKAGE_SEARCH_DEPTH = 6
MIB = 1 << 20


@dataclass(frozen=True)
class SandboxLimits:
    """Limits of one expansion (the worker's own ``setrlimit`` and the caller's clock).

    ``cpu_seconds`` (``RLIMIT_CPU``), ``memory_bytes`` (``RLIMIT_AS``: the worker's address
    space, Python included), ``output_bytes`` (the expanded URDF), ``wall_seconds`` (killed
    after that), ``max_macro_calls`` (expansion bombs), ``max_expression_chars``.
    """

    cpu_seconds: float = 10.0
    memory_bytes: int = 1024 * MIB
    output_bytes: int = 8 * MIB
    wall_seconds: float = 30.0
    max_macro_calls: int = 20_000
    max_expression_chars: int = 10_000


DEFAULT_LIMITS = SandboxLimits()


@dataclass(frozen=True)
class Expansion:
    """The URDF a xacro document expanded to, with the arguments used."""

    urdf: str
    args: Mapping[str, str] = field(default_factory=dict)


def check_args(args: Mapping[str, object] | None) -> dict[str, str]:
    """xacro arguments as ``{name: str(value)}``; names must be plain identifiers."""
    out: dict[str, str] = {}
    for k, v in (args or {}).items():
        if not isinstance(k, str) or not _NAME.match(k):
            raise XacroError(f"xacro argument name {str(k)[:60]!r} is not a plain name")
        if isinstance(v, bool):
            v = "true" if v else "false"
        if not isinstance(v, (str, int, float)):
            raise XacroError(f"xacro argument {k!r}: give a string or a number, not {type(v).__name__}")
        v = str(v)
        if len(v) > 10_000:
            raise XacroError(f"xacro argument {k!r} is longer than 10000 characters")
        out[k] = v
    return out


def _package_name(package_xml: Path) -> str | None:
    try:
        data = package_xml.read_bytes()[: 1 * MIB]
        root = safe_fromstring(data, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except (OSError, DefusedXmlException, Exception):  # noqa: BLE001 - a bad package.xml names no package
        return None
    name = (root.findtext("name") or "").strip()
    return name if _NAME.match(name) else None


def find_packages(dirs: Iterable[os.PathLike | str]) -> dict[str, Path]:
    """ROS packages under ``dirs``: every directory holding a ``package.xml`` (named by its
    ``<name>``), and -- for trees without them -- every directory by its own name (a package.xml
    name wins; among directory names, the shallowest), plus the renamings collections such as
    rtb-data made (``X_support`` and ``X`` for ``X_description`` when no package has that
    name). Symbolic links are not followed."""
    by_xml: dict[str, Path] = {}
    by_dir: dict[str, tuple[int, Path]] = {}
    for base in dirs:
        base = Path(base).resolve()
        if not base.is_dir():
            raise XacroError(f"package path {str(base)!r} is not a directory")
        base_depth = len(base.parts)
        for here, subdirs, files in os.walk(base, followlinks=False):
            p = Path(here)
            depth = len(p.parts) - base_depth
            subdirs[:] = sorted(d for d in subdirs if not d.startswith(".")) if depth < PACKAGE_SEARCH_DEPTH else []
            if "package.xml" in files:
                name = _package_name(p / "package.xml")
                if name and name not in by_xml:
                    by_xml[name] = p
            if _NAME.match(p.name) and (p.name not in by_dir or by_dir[p.name][0] > depth):
                by_dir[p.name] = (depth, p)
    out = {name: path for name, (_, path) in by_dir.items()}
    out.update(by_xml)
    for name, path in list(out.items()):  # the renamings of packages collected in one tree (rtb-data)
        aliases = [name + "_support"] + ([name[: -len("_description")]] if name.endswith("_description") else [])
        for alias in aliases:
            out.setdefault(alias, path)
    return out


def _check_xml(data: bytes, what: str) -> None:
    """Refuse DTDs and entities (billion laughs, XXE) before any process is started."""
    try:
        safe_fromstring(data, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DefusedXmlException as exc:
        raise XacroError(f"{what} refused: it declares a DTD or entities ({type(exc).__name__}); "
                         "entity expansion and external entities are disabled") from None
    except Exception as exc:  # noqa: BLE001 - ParseError, encoding errors
        raise XacroError(f"{what} is not well-formed XML: {exc}") from None


def _require_xacro() -> None:
    """The worker runs this interpreter: without the ``xacro`` extra it would fail there, unexplained."""
    try:
        found = importlib.util.find_spec("xacro") is not None
    except (ImportError, ValueError):
        found = False
    if not found:
        raise MissingExtraError.of("xacro", "xacro expansion", "xacro")


def expand(entry: os.PathLike | str, *, roots: Iterable[os.PathLike | str], packages: Mapping[str, os.PathLike | str] | None = None,
           args: Mapping[str, object] | None = None, limits: SandboxLimits = DEFAULT_LIMITS) -> Expansion:
    """Expand the xacro file ``entry`` in the sandboxed worker; files may be read only under ``roots``.

    Raises :class:`~kinematics.errors.XacroError` (a message naming the file, the macro or the
    refused path) or :class:`~kinematics.errors.ExpansionLimitError` (over a limit).
    """
    _require_xacro()
    entry = Path(entry).resolve()
    roots = [str(Path(r).resolve()) for r in roots]
    checked = check_args(args)
    job = {
        "entry": str(entry), "cwd": str(entry.parent), "roots": roots, "args": checked,
        "packages": {k: str(Path(v).resolve()) for k, v in (packages or {}).items()},
        "limits": {"cpu_seconds": limits.cpu_seconds, "memory_bytes": int(limits.memory_bytes),
                   "output_bytes": int(limits.output_bytes), "max_macro_calls": int(limits.max_macro_calls),
                   "max_expression_chars": int(limits.max_expression_chars)},
    }
    with tempfile.TemporaryDirectory(prefix="kin-xacro-out-") as out_dir:
        out_path = os.path.join(out_dir, "answer.json")
        with open(out_path, "w+b") as out, open(os.devnull, "wb") as devnull:
            try:
                proc = subprocess.Popen(
                    [sys.executable, "-I", "-B", str(WORKER)], stdin=subprocess.PIPE, stdout=out, stderr=devnull,
                    cwd=str(entry.parent), env={"PATH": "/usr/bin:/bin", "LANG": "C.UTF-8", "LC_ALL": "C.UTF-8"},
                    close_fds=True, start_new_session=True,
                )
            except OSError as exc:
                raise XacroError(f"the xacro sandbox could not be started: {exc}") from None
            try:
                proc.communicate(json.dumps(job).encode(), timeout=limits.wall_seconds)
            except subprocess.TimeoutExpired:
                _kill(proc)
                raise ExpansionLimitError(f"xacro expansion took longer than {limits.wall_seconds:g} s and was stopped") from None
            except BaseException:
                _kill(proc)
                raise
            out.seek(0)
            raw = out.read(limits.output_bytes + 2 * 65536)
    code = proc.returncode
    if code in (-signal.SIGXCPU, -signal.SIGKILL) and not raw:
        raise ExpansionLimitError(f"xacro expansion exceeded its CPU time limit ({limits.cpu_seconds:g} s) and was stopped")
    if code == -signal.SIGXFSZ:
        raise ExpansionLimitError(f"the expanded URDF is over the output limit ({limits.output_bytes} bytes)")
    try:
        answer = json.loads(raw)
    except ValueError:
        if code and code < 0:
            raise ExpansionLimitError(
                f"xacro expansion was stopped by signal {-code} ({signal.Signals(-code).name}): over its CPU time "
                f"({limits.cpu_seconds:g} s) or memory ({limits.memory_bytes // MIB} MiB) limit") from None
        raise ExpansionLimitError(f"xacro expansion failed without an answer (exit code {code}): over its memory "
                                  f"limit ({limits.memory_bytes // MIB} MiB)?") from None
    if not answer.get("ok"):
        message = str(answer.get("error") or "xacro expansion failed")
        for root in roots:  # name files as the user knows them, not by the sandbox's path
            message = message.replace(root + os.sep, "").replace(root, ".")
        where = answer.get("file")
        if where:
            for root in roots:
                where = where.replace(root + os.sep, "")
            if where not in message:
                message = f"{message} (in {where})"
        cls = ExpansionLimitError if answer.get("kind") == "limit" else XacroError
        raise cls(f"xacro: {message}")
    return Expansion(urdf=answer["urdf"], args=checked)


def _kill(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    proc.wait()


def expand_text(text: str | bytes, *, args: Mapping[str, object] | None = None,
                limits: SandboxLimits = DEFAULT_LIMITS) -> Expansion:
    """Expand xacro *text* (an upload) in a temporary directory that holds nothing else."""
    data = text.encode("utf-8") if isinstance(text, str) else bytes(text)
    _check_xml(data, "xacro document")
    with tempfile.TemporaryDirectory(prefix="kin-xacro-") as tmp:
        path = Path(tmp) / UPLOAD_NAME
        path.write_bytes(data)
        return expand(path, roots=[tmp], packages={}, args=args, limits=limits)


def _parse_expanded(expansion: Expansion, max_links: int) -> RobotModel:
    try:
        return parse_urdf(expansion.urdf, max_links=max_links)
    except XacroError:
        raise
    except URDFError as exc:
        if "has no <link>" in str(exc) or "no 'name' attribute" in str(exc):
            raise URDFError(f"{exc} after xacro expansion: a file that only defines macros makes no robot; "
                            "load the file that calls them") from None
        raise


def with_format(model: RobotModel, fmt: str, warnings: Iterable[str] = ()) -> RobotModel:
    """``model`` marked as read from ``fmt`` (``xacro``, ``mjcf``, ``archive``), with extra warnings first."""
    return replace(model, format=fmt, warnings=tuple(warnings) + tuple(model.warnings))


def parse_xacro(text: str | bytes, *, args: Mapping[str, object] | None = None, limits: SandboxLimits = DEFAULT_LIMITS,
                max_links: int = DEFAULT_MAX_LINKS) -> RobotModel:
    """Build a model from xacro text (sandboxed expansion, then :func:`parse_urdf`)."""
    expansion = expand_text(text, args=args, limits=limits)
    return with_format(_parse_expanded(expansion, max_links), "xacro")


def load_xacro(path: os.PathLike | str, *, args: Mapping[str, object] | None = None,
               package_paths: Iterable[os.PathLike | str] = (), limits: SandboxLimits = DEFAULT_LIMITS,
               max_links: int = DEFAULT_MAX_LINKS) -> RobotModel:
    """Build a model from a xacro file: readable are its directory and ``package_paths``,
    whose packages ``$(find pkg)`` resolves (meshes are never opened)."""
    path = Path(path)
    data = path.read_bytes()  # OSError for a missing file, as load_urdf
    _check_xml(data, f"xacro file {path.name!r}")
    dirs = [path.resolve().parent, *[Path(p) for p in package_paths]]
    packages = find_packages(package_paths)
    expansion = expand(path, roots=dirs, packages=packages, args=args, limits=limits)
    return with_format(_parse_expanded(expansion, max_links), "xacro")
