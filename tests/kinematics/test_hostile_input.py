"""Hostile and malformed input at the library level (``kinematics``), from ``tests/corpus/``.

- every URDF of the corpus is refused by :func:`kinematics.parse_urdf` with the expected
  exception class and a message naming the problem;
- XML bombs (XXE, parameter entities, external DTD, billion laughs, quadratic blow-up)
  are refused before any entity is expanded: bounded memory (tracemalloc peak), no file
  opened, no socket touched (audit hook);
- the link/joint count limit holds;
- DH corpus tables are refused by :func:`kinematics.io.dh_table.table_from_dict` naming the field;
- regressions for the bugs this hardening found (huge axis components, one-DOF
  Pinocchio Jacobian).
"""

from __future__ import annotations

import json
import sys
import threading
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import yaml

import kinematics.errors as kerrors
from kinematics import REFERENCES, as_batch, compile_model, parse_urdf
from kinematics.io.urdf import DEFAULT_MAX_LINKS
from tests.paths import CORPUS
from kinematics.io import dh_table as dh

MANIFEST = yaml.safe_load((CORPUS / "manifest.yaml").read_text())

#: peak Python heap while refusing an XML bomb (the billion-laughs expansion is ~3 GB)
BOMB_PEAK_BYTES = 4 * 1024 * 1024

# ---------------------------------------------------------------- audit hook (one per process)
_AUDIT = threading.local()
_WATCHED_EVENTS = {"open", "socket.connect", "socket.getaddrinfo", "urllib.Request", "subprocess.Popen", "os.system"}


def _hook(event, args):
    log = getattr(_AUDIT, "log", None)
    if log is not None and event in _WATCHED_EVENTS:
        log.append((event, args[0] if args else None))


sys.addaudithook(_hook)


class audited:
    """Record file opens and network use by this thread inside the block."""

    def __enter__(self):
        self.events = []
        _AUDIT.log = self.events
        return self

    def __exit__(self, *exc):
        _AUDIT.log = None
        return False


def _ids(items):
    return [Path(i["file"]).stem for i in items]


# ---------------------------------------------------------------- URDF corpus
@pytest.mark.parametrize("item", MANIFEST["urdf"], ids=_ids(MANIFEST["urdf"]))
def test_corpus_urdf_is_refused_naming_the_problem(item):
    data = (CORPUS / item["file"]).read_bytes()
    expected = getattr(kerrors, item["error"])
    with pytest.raises(kerrors.URDFError) as info:
        parse_urdf(data)
    assert type(info.value) is expected
    assert item.get("lib_contains", item["contains"]).lower() in str(info.value).lower()


def test_corpus_is_big_enough_and_every_file_is_listed():
    listed = {i["file"] for i in MANIFEST["urdf"]} | {i["file"] for i in MANIFEST["dh"]}
    on_disk = {str(p.relative_to(CORPUS)) for p in CORPUS.glob("urdf/*")} | {
        str(p.relative_to(CORPUS)) for p in CORPUS.glob("dh/*")
    }
    assert listed == on_disk
    total = len(MANIFEST["urdf"]) + len(MANIFEST["dh"]) + len(MANIFEST.get("requests", []))
    assert total >= 30


HOSTILE = [i for i in MANIFEST["urdf"] if i.get("hostile")]


@pytest.mark.parametrize("item", HOSTILE, ids=_ids(HOSTILE))
def test_xml_bombs_are_refused_with_bounded_memory_and_no_io(item):
    data = (CORPUS / item["file"]).read_bytes()
    tracemalloc.start()
    try:
        with audited() as audit, pytest.raises(kerrors.URDFError, match="DTD"):
            parse_urdf(data)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < BOMB_PEAK_BYTES, f"peak {peak} bytes while refusing {item['file']}"
    assert audit.events == [], audit.events


def test_audit_hook_sees_opens_and_sockets():
    """The detector of the test above can fail: it records a real open and a real lookup."""
    import socket

    with audited() as audit:
        open(__file__, "rb").close()
        try:
            socket.getaddrinfo("127.0.0.1", 9)
        except OSError:
            pass
    kinds = [e for e, _ in audit.events]
    assert "open" in kinds and "socket.getaddrinfo" in kinds


def test_xml_refused_even_with_only_an_internal_dtd():
    """Any DOCTYPE is refused (defusedxml forbid_dtd), even one that declares nothing."""
    with pytest.raises(kerrors.URDFError, match="DTD"):
        parse_urdf('<?xml version="1.0"?><!DOCTYPE robot []><robot name="r"><link name="a"/></robot>')


def test_xinclude_is_not_processed():
    """An XInclude element is inert: the file it names is not read (it's just an unknown tag)."""
    text = (
        '<robot name="r" xmlns:xi="http://www.w3.org/2001/XInclude">'
        '<link name="a"><xi:include href="/etc/passwd" parse="text"/></link></robot>'
    )
    with audited() as audit:
        model = parse_urdf(text)
    assert model.links == ("a",)
    assert not [a for e, a in audit.events if e == "open" and "passwd" in str(a)]


def _chain(n_links: int) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n_links))
    joints = "".join(
        f'<joint name="j{i}" type="fixed"><parent link="l{i - 1}"/><child link="l{i}"/></joint>'
        for i in range(1, n_links)
    )
    return f'<robot name="big">{links}{joints}</robot>'


def test_link_limit():
    assert len(parse_urdf(_chain(5), max_links=5).links) == 5
    with pytest.raises(kerrors.ModelTooLargeError, match="limit is 4"):
        parse_urdf(_chain(5), max_links=4)
    with pytest.raises(kerrors.URDFError, match=f"limit is {DEFAULT_MAX_LINKS}"):
        parse_urdf(_chain(DEFAULT_MAX_LINKS + 1))


def test_deeply_nested_xml_is_handled():
    """100k nested unknown elements: either parsed (ignored) or refused as URDFError, never a crash."""
    depth = 100_000
    text = '<robot name="deep"><link name="a">' + "<x>" * depth + "</x>" * depth + "</link></robot>"
    try:
        model = parse_urdf(text)
    except kerrors.URDFError:
        return
    assert model.links == ("a",) and model.dof == 0


# ---------------------------------------------------------------- bugs found by this hardening
def _one_joint(axis: str, jtype: str = "revolute") -> str:
    return (
        '<robot name="r"><link name="a"/><link name="b"/>'
        f'<joint name="j" type="{jtype}"><parent link="a"/><child link="b"/><axis xyz="{axis}"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )


@pytest.mark.parametrize(
    "axis, unit",
    [("1e200 0 0", (1, 0, 0)), ("1e308 1e308 0", (2**-0.5, 2**-0.5, 0)), ("0 0 -3e300", (0, 0, -1))],
)
def test_huge_axis_components_are_normalised_not_zeroed(axis, unit):
    """Was: |axis|^2 overflowed to inf and the axis became (0, 0, 0): a joint that never moves."""
    model = parse_urdf(_one_joint(axis))
    np.testing.assert_allclose(model.joints[0].axis, unit, rtol=0, atol=1e-15)
    T = compile_model(model).fk(np.array([[0.5]]), ["b"])[0, 0]
    assert abs(np.trace(T[:3, :3]) - (1 + 2 * np.cos(0.5))) < 1e-12  # a rotation by 0.5 rad


def test_tiny_axis_is_refused_as_zero():
    with pytest.raises(kerrors.URDFError, match="zero <axis>"):
        parse_urdf(_one_joint("1e-200 0 0"))


def test_pinocchio_jacobian_of_a_one_dof_model():
    """Was: eigenpy returned the 6x1 Jacobian as shape (6,) and compare_jacobian raised IndexError."""
    from kinematics.verify import pinocchio as crosscheck

    model = parse_urdf(_one_joint("0 0 1"))
    Q = np.array([[0.3], [-0.7]])
    assert crosscheck.compare_jacobian(model, Q, "b") < 1e-12
    ref = crosscheck.reference_for(model).jacobian(Q[0], "b", "world")
    assert ref.shape == (6, 1) and abs(ref[5, 0] - 1.0) < 1e-12


def test_extreme_legal_values_keep_fk_and_jacobians_finite():
    """Was: finite but huge origins / q (1e308) overflowed to inf and the API answered 200 with
    nulls. Now inputs are bounded (MAX_ABS_COORDINATE, MAX_ABS_JOINT_VALUE); at the bounds,
    a long prismatic chain with mimic multipliers still gives finite results."""
    from kinematics.tolerances import MAX_ABS_JOINT_VALUE
    from kinematics.tolerances import MAX_ABS_COORDINATE

    n = 200
    B = MAX_ABS_COORDINATE
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = "".join(
        f'<joint name="j{i}" type="prismatic"><parent link="l{i - 1}"/><child link="l{i}"/>'
        f'<origin xyz="{B:g} {-B:g} {B:g}" rpy="{B:g} 0 {-B:g}"/><axis xyz="1 1 0"/>'
        + (f'<mimic joint="j1" multiplier="{B:g}" offset="{-B:g}"/>' if i > 1 else "")
        + "</joint>"
        for i in range(1, n + 1)
    )
    model = parse_urdf(f'<robot name="extreme">{links}{joints}</robot>')
    Q = np.array([[MAX_ABS_JOINT_VALUE], [-MAX_ABS_JOINT_VALUE]])
    poe = compile_model(model)
    assert np.all(np.isfinite(poe.fk(Q, list(model.links))))
    for r in REFERENCES:
        assert np.all(np.isfinite(poe.jacobian(Q, f"l{n}", r)))
    with pytest.raises(kerrors.JointValueError, match=r"joint 'j1': value 1e\+07 is beyond"):
        as_batch(model, [1e7])
    with pytest.raises(kerrors.JointValueError, match=r"configuration 1, joint 'j1': value -1e\+308"):
        as_batch(model, [[0.0], [-1e308]])


# ---------------------------------------------------------------- joint values
@pytest.fixture(scope="module")
def arm():
    return parse_urdf((CORPUS / "fixture_arm.urdf").read_bytes())


@pytest.mark.parametrize(
    "q, contains",
    [
        ([0.0, 0.0], "expected 3 joint values"),
        ([0.0, float("nan"), 0.0], "'j2': value nan is not finite"),
        ([0.0, 0.0, float("inf")], "'j3': value inf is not finite"),
        ([0.0, "1", 0.0], "'j2': value '1' is not a number"),
        ([0.0, True, 0.0], "is not a number"),
        ([0.0, None, 0.0], "is not a number"),
        ([[0.0, 0.0, 0.0], [0.0, 0.0]], "configuration 1: expected 3"),
        ([0.0, [0.0], 0.0], "mixes numbers and lists"),
        ({"j1": 0.0, "j2": 0.0}, "missing value(s) for joint(s): j3"),
        ({"j1": 0.0, "j2": 0.0, "j3": 0.0, "ghost": 1.0}, "unknown joint name(s): ghost"),
        ("0 0 0", "q must be"),
        (3.0, "q must be"),
        (np.zeros((2, 3, 1)), "shape"),
        (np.array([["a", "b", "c"]]), "dtype"),
        (np.array([[1, 2, 3]], dtype=object), "dtype object"),
    ],
)
def test_bad_joint_values_name_the_problem(arm, q, contains):
    with pytest.raises(kerrors.JointValueError) as info:
        as_batch(arm, q)
    assert contains in str(info.value)


def test_object_npy_is_refused_without_unpickling(tmp_path, arm):
    """A .npy holding an object array carries a pickle: loading it as q must not unpickle."""
    path = tmp_path / "q.npy"
    np.save(path, np.array([[0.0, {"x": 1}, 0.0]], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match="allow_pickle"):
        np.load(path, allow_pickle=False)
    # and an object array that got in anyway is refused by as_batch
    with pytest.raises(kerrors.JointValueError, match="dtype object"):
        as_batch(arm, np.load(path, allow_pickle=True))


# ---------------------------------------------------------------- DH corpus (library side)
@pytest.mark.parametrize("item", MANIFEST["dh"], ids=_ids(MANIFEST["dh"]))
def test_corpus_dh_table_is_refused_naming_the_field(item):
    table = json.loads((CORPUS / item["file"]).read_text())  # NaN / Infinity literals allowed
    if item.get("error") is None:
        pytest.skip("refused by the wire schema only")
    with pytest.raises(getattr(kerrors, item["error"])) as info:
        dh.table_from_dict(table)
    assert item.get("lib_contains", item["contains"]).lower() in str(info.value).lower()


# ---------------------------------------------------------------- descriptions: xacro, MJCF, archives
from kinematics.io.archive import ArchiveLimits  # noqa: E402
from kinematics.io.description import load_description  # noqa: E402
from kinematics.io.xacro import SandboxLimits  # noqa: E402
from tests.corpus import archives  # noqa: E402

DESCRIPTIONS = MANIFEST["descriptions"]
#: the sandbox's limits in these tests (the service's test app uses the same)
TEST_XACRO_LIMITS = SandboxLimits(cpu_seconds=2, memory_bytes=512 * 1024 * 1024, wall_seconds=20)
#: the archive limits of the "small" app
SMALL_ARCHIVE_LIMITS = ArchiveLimits(max_members=50, max_bytes=archives.SMALL_ARCHIVE_BYTES,
                                     max_stream_bytes=8 * archives.SMALL_ARCHIVE_BYTES)


def description_bytes(item) -> bytes:
    return (CORPUS / item["file"]).read_bytes() if "file" in item else archives.build(item["generate"])


def _desc_ids(items):
    return [Path(i["file"]).stem if "file" in i else i["generate"] for i in items]


@pytest.mark.parametrize("item", DESCRIPTIONS, ids=_desc_ids(DESCRIPTIONS))
def test_corpus_description_is_refused_naming_the_problem(item):
    data = description_bytes(item)
    limits = SMALL_ARCHIVE_LIMITS if item.get("app") == "small" else ArchiveLimits()
    pwned = Path("/tmp/pwned")
    pwned.unlink(missing_ok=True)
    with audited() as audit, pytest.raises(kerrors.URDFError) as info:
        load_description(data, xacro_limits=TEST_XACRO_LIMITS, archive_limits=limits)
    assert type(info.value) is getattr(kerrors, item["error"]), repr(info.value)
    assert item.get("lib_contains", item["contains"]).lower() in str(info.value).lower(), str(info.value)
    if "secret" in item:
        assert item["secret"] not in str(info.value)
    assert not [a for e, a in audit.events if e == "open" and "passwd" in str(a)]  # this process read nothing
    assert not pwned.exists()  # and the sandbox ran no command


def test_every_description_file_is_listed():
    listed = {i["file"] for i in DESCRIPTIONS if "file" in i}
    assert listed == {str(p.relative_to(CORPUS)) for p in CORPUS.glob("descriptions/*")}
    assert {i["generate"] for i in DESCRIPTIONS if "generate" in i} == set(archives.BUILDERS)
