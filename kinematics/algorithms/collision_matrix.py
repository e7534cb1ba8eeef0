"""The allowed-collision matrix: link pairs never checked, each with its reason, as MoveIt's Setup Assistant makes them.

Over the links with collision geometry (:class:`~kinematics.algorithms.collision.CollisionModel`):

* ``adjacent`` -- the parent and child links of a joint. As in the Setup Assistant's connection
  graph, a link without collision geometry joins its neighbours: they are adjacent to each other
  (through any chain of geometry-less links), so ``link7 - link8 (no geometry) - hand`` makes
  ``(link7, hand)`` adjacent.
* ``always`` -- in collision in at least ``always_fraction`` (default 1: every one) of the sampled
  configurations (meshes that overlap by design).
* ``never`` -- in collision in none of the ``samples`` random configurations (uniform within the
  limits, a fixed seed: the same model gives the same matrix). Default 10,000 samples.
* ``user`` -- pairs a caller disables.

A pair that is both adjacent and something else is ``adjacent`` (the first reason wins, in that
order). The checked pairs are the others: :attr:`CollisionMatrix.enabled`.

A user changes a matrix with :class:`UserPairs`: ``allow`` disables pairs (a gripper holding a
tool, a calibration rig: reason ``user``), ``forbid`` enables pairs the matrix disabled (a pair
the sampling called ``never`` that a task reaches): :meth:`CollisionMatrix.with_pairs`. The
forbidden pairs are listed in :attr:`CollisionMatrix.forced` and exported as SRDF
``enable_collisions``.

:func:`collision_matrix` computes it once per model, geometry and settings and keeps it as JSON
in ``cache_dir`` (keyed by the model's content hash, the geometry's fingerprint and the
settings), so a second call -- in this process or the next -- reads it back.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import CollisionError, did_you_mean
from .collision import CollisionModel

#: reasons, in the order they are decided
REASONS = ("adjacent", "always", "never", "user")
DEFAULT_SAMPLES = 10_000
#: bump when the way a matrix is computed changes (old cache files are then ignored)
MATRIX_VERSION = 1


Pair = tuple[str, str]


def _pairs(pairs, what: str) -> tuple[Pair, ...]:
    out = []
    for pair in pairs:
        if isinstance(pair, str) or len(pair) != 2 or not all(isinstance(n, str) for n in pair):
            raise CollisionError(f"{what}: a pair names two links, got {pair!r}")
        out.append((pair[0], pair[1]))
    return tuple(out)


@dataclass(frozen=True)
class UserPairs:
    """The pairs a user sets on a matrix: ``allow`` (never checked: disabled, reason ``user``) and
    ``forbid`` (always checked, whatever the matrix's reason). A pair in both is refused.
    :meth:`then` lays another set over this one (its choices win): a request over a model's
    settings.

    >>> UserPairs(allow=[("a", "b")]).then(UserPairs(forbid=[("b", "a")]))
    UserPairs(allow=(), forbid=(('b', 'a'),))
    """

    allow: tuple[Pair, ...] = ()
    forbid: tuple[Pair, ...] = ()

    def __post_init__(self) -> None:
        allow, forbid = _pairs(self.allow, "allow"), _pairs(self.forbid, "forbid")
        forbidden = {frozenset(p) for p in forbid}
        for a, b in allow:
            if frozenset((a, b)) in forbidden:
                raise CollisionError(f"the pair ({a!r}, {b!r}) is both allowed and forbidden")
        object.__setattr__(self, "allow", allow)
        object.__setattr__(self, "forbid", forbid)

    def __bool__(self) -> bool:
        return bool(self.allow or self.forbid)

    def then(self, other: "UserPairs | None") -> "UserPairs":
        """These pairs with ``other``'s laid over them: a pair ``other`` names takes its choice."""
        if not other:
            return self
        named = {frozenset(p) for p in other.allow + other.forbid}
        keep = [p for p in self.allow if frozenset(p) not in named], [p for p in self.forbid if frozenset(p) not in named]
        return UserPairs(tuple(keep[0]) + other.allow, tuple(keep[1]) + other.forbid)

    def as_dict(self) -> dict:
        return {"allow": [list(p) for p in self.allow], "forbid": [list(p) for p in self.forbid]}


@dataclass(frozen=True)
class CollisionMatrix:
    """``links`` (with geometry), ``disabled`` ({(a, b): reason}, ``a`` before ``b`` in ``links``),
    ``samples`` (configurations sampled), ``counts`` ({pair: configurations in collision}),
    ``forced`` (pairs a user forbids that the matrix would disable: checked all the same)."""

    links: tuple[str, ...]
    disabled: dict[tuple[str, str], str]
    samples: int
    counts: dict[tuple[str, str], int] = field(default_factory=dict, repr=False)
    forced: tuple[tuple[str, str], ...] = ()

    def enabled(self) -> list[tuple[str, str]]:
        """The pairs a check looks at: every pair of ``links`` not disabled, ``links`` order."""
        return [(a, b) for i, a in enumerate(self.links) for b in self.links[i + 1:] if (a, b) not in self.disabled]

    def with_user(self, pairs: Sequence[Sequence[str]]) -> "CollisionMatrix":
        """This matrix with ``pairs`` also disabled (reason ``user``, unless already disabled)."""
        return self.with_pairs(UserPairs(allow=pairs))

    def key(self, pair: Sequence[str], what: str = "a pair", model_links: Sequence[str] = ()) -> Pair:
        """``pair`` ordered as in ``links``; a name that is no link of the model (``model_links``,
        when given) or one without collision geometry raises :class:`CollisionError` naming it."""
        index = {name: i for i, name in enumerate(self.links)}
        a, b = pair
        for name in (a, b):
            if name not in index:
                if model_links and name not in model_links:
                    raise CollisionError(f"{what}: unknown link {name!r}" + did_you_mean(name, list(model_links), "links"))
                raise CollisionError(f"{what}: link {name!r} has no collision geometry; it cannot be in a pair "
                                     f"(links with geometry: {', '.join(self.links) or 'none'})")
        if a == b:
            raise CollisionError(f"{what}: the pair ({a!r}, {b!r}) names one link twice")
        return (a, b) if index[a] < index[b] else (b, a)

    def with_pairs(self, user: UserPairs | None, model_links: Sequence[str] = ()) -> "CollisionMatrix":
        """This matrix with a user's pairs: ``user.allow`` disabled (reason ``user``, unless already
        disabled for another reason), ``user.forbid`` enabled (removed from ``disabled``; those the
        matrix disabled are listed in :attr:`forced`). Names are checked (see :meth:`key`)."""
        if not user:
            return self
        disabled = dict(self.disabled)
        forced = list(self.forced)
        for pair in user.forbid:
            key = self.key(pair, "forbid", model_links)
            if disabled.pop(key, None) is not None and key not in forced:
                forced.append(key)
        for pair in user.allow:
            key = self.key(pair, "allow", model_links)
            if key in forced:
                forced.remove(key)
            disabled.setdefault(key, "user")
        return CollisionMatrix(self.links, disabled, self.samples, self.counts, tuple(forced))

    def as_dict(self) -> dict:
        """``{"links", "disabled": [{"links": [a, b], "reason"}], "samples"}`` (pairs in ``links`` order)."""
        index = {name: i for i, name in enumerate(self.links)}
        rows = sorted(self.disabled.items(), key=lambda kv: (index[kv[0][0]], index[kv[0][1]]))
        return {"links": list(self.links), "disabled": [{"links": [a, b], "reason": r} for (a, b), r in rows],
                "enabled": [{"links": [a, b], "reason": "user"} for a, b in self.forced], "samples": self.samples}

    def to_srdf(self, robot: str) -> str:
        """The matrix as an SRDF document of ``disable_collisions`` elements (MoveIt's reasons:
        ``Adjacent``, ``Always``, ``Never``, ``User``), then an ``enable_collisions`` element
        (reason ``User``) per pair a user forbids that the matrix would disable.

        >>> CollisionMatrix(("a", "b"), {("a", "b"): "adjacent"}, 10).to_srdf("r").splitlines()[2]
        '    <disable_collisions link1="a" link2="b" reason="Adjacent"/>'
        """
        lines = ['<?xml version="1.0" encoding="utf-8"?>', f"<robot name={quoteattr(robot)}>"]
        for row in self.as_dict()["disabled"]:
            a, b = row["links"]
            lines.append(f"    <disable_collisions link1={quoteattr(a)} link2={quoteattr(b)} "
                         f"reason={quoteattr(row['reason'].capitalize())}/>")
        for a, b in self.forced:
            lines.append(f'    <enable_collisions link1={quoteattr(a)} link2={quoteattr(b)} reason="User"/>')
        lines.append("</robot>")
        return "\n".join(lines) + "\n"


def adjacent_pairs(cm: CollisionModel) -> set[tuple[str, str]]:
    """Pairs of links with geometry that are adjacent (see the module doc), ``links`` order."""
    model = cm.model
    has = set(cm.links)
    graph: dict[str, set[str]] = {name: set() for name in model.links}
    for j in model.joints:
        graph[j.parent].add(j.child)
        graph[j.child].add(j.parent)
    out: set[tuple[str, str]] = set()
    index = cm.link_index
    for a in cm.links:
        # every link with geometry reached from a through links without geometry only
        seen, stack = {a}, [a]
        while stack:
            for nb in graph[stack.pop()]:
                if nb in seen:
                    continue
                seen.add(nb)
                if nb in has:
                    out.add((a, nb) if index[a] < index[nb] else (nb, a))
                else:
                    stack.append(nb)
    return out


def compute_matrix(cm: CollisionModel, samples: int = DEFAULT_SAMPLES, *, always_fraction: float = 1.0,
                   seed: int = 0, progress: Callable[[int], None] | None = None) -> CollisionMatrix:
    """The matrix of ``cm`` from ``samples`` random configurations (see the module doc);
    ``progress(k)`` is told the configurations done."""
    if not 1 <= samples <= 10_000_000:
        raise CollisionError(f"samples must be in [1, 10000000], got {samples!r}")
    if not 0.0 < always_fraction <= 1.0:
        raise CollisionError(f"always_fraction must be in (0, 1], got {always_fraction!r}")
    adjacent = adjacent_pairs(cm)
    disabled: dict[tuple[str, str], str] = {p: "adjacent" for p in adjacent}
    others = [p for p in cm.all_pairs() if p not in adjacent]
    counts = {p: 0 for p in others}
    if others:
        Q = cm.model.sample_configurations(samples, np.random.default_rng(seed), continuous_range=np.pi)
        result = cm.check(Q, others, progress=progress)
        for row in result.pairs:
            for p in row:
                counts[p] += 1
    elif progress is not None:
        progress(samples)
    for p, c in counts.items():
        if c >= always_fraction * samples:
            disabled[p] = "always"
        elif c == 0:
            disabled[p] = "never"
    return CollisionMatrix(cm.links, disabled, samples, counts)


def cache_key(cm: CollisionModel, samples: int, always_fraction: float, seed: int) -> str:
    """The name a matrix is kept under: model text, geometry, settings and the computation's version."""
    text = json.dumps([MATRIX_VERSION, cm.model.content_hash, cm.geometry.fingerprint(), list(cm.links),
                       samples, always_fraction, seed])
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def collision_matrix(cm: CollisionModel, samples: int = DEFAULT_SAMPLES, *, always_fraction: float = 1.0,
                     seed: int = 0, cache_dir: os.PathLike | str | None = None,
                     progress: Callable[[int], None] | None = None) -> CollisionMatrix:
    """:func:`compute_matrix`, read from ``cache_dir`` when it was computed before (and written
    there when it was not; a cache that cannot be read or written is recomputed, never fatal)."""
    path = None
    if cache_dir is not None:
        path = Path(cache_dir) / f"collision-matrix-{cache_key(cm, samples, always_fraction, seed)}.json"
        try:
            stored = json.loads(path.read_text())
            disabled = {tuple(row["links"]): row["reason"] for row in stored["disabled"]}
            counts = {tuple(row[0]): int(row[1]) for row in stored.get("counts", [])}
            if tuple(stored["links"]) == cm.links and all(r in REASONS for r in disabled.values()):
                if progress is not None:
                    progress(samples)
                return CollisionMatrix(cm.links, disabled, int(stored["samples"]), counts)
        except (OSError, ValueError, KeyError, TypeError):
            pass
    matrix = compute_matrix(cm, samples, always_fraction=always_fraction, seed=seed, progress=progress)
    if path is not None:
        doc = matrix.as_dict()
        doc["counts"] = [[list(p), c] for p, c in matrix.counts.items()]
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".matrix-", suffix=".json")
            with os.fdopen(fd, "w") as fh:
                json.dump(doc, fh)
            os.replace(tmp, path)
        except OSError:
            pass
    return matrix
