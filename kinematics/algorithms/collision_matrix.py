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

from ..errors import CollisionError
from .collision import CollisionModel

#: reasons, in the order they are decided
REASONS = ("adjacent", "always", "never", "user")
DEFAULT_SAMPLES = 10_000
#: bump when the way a matrix is computed changes (old cache files are then ignored)
MATRIX_VERSION = 1


@dataclass(frozen=True)
class CollisionMatrix:
    """``links`` (with geometry), ``disabled`` ({(a, b): reason}, ``a`` before ``b`` in ``links``),
    ``samples`` (configurations sampled), ``counts`` ({pair: configurations in collision})."""

    links: tuple[str, ...]
    disabled: dict[tuple[str, str], str]
    samples: int
    counts: dict[tuple[str, str], int] = field(default_factory=dict, repr=False)

    def enabled(self) -> list[tuple[str, str]]:
        """The pairs a check looks at: every pair of ``links`` not disabled, ``links`` order."""
        return [(a, b) for i, a in enumerate(self.links) for b in self.links[i + 1:] if (a, b) not in self.disabled]

    def with_user(self, pairs: Sequence[Sequence[str]]) -> "CollisionMatrix":
        """This matrix with ``pairs`` also disabled (reason ``user``, unless already disabled)."""
        index = {name: i for i, name in enumerate(self.links)}
        disabled = dict(self.disabled)
        for pair in pairs:
            if len(pair) != 2:
                raise CollisionError(f"a disabled pair names two links, got {list(pair)!r}")
            a, b = pair
            for name in (a, b):
                if name not in index:
                    raise CollisionError(f"link {name!r} has no collision geometry; it cannot be in a disabled pair")
            if a == b:
                raise CollisionError(f"the pair ({a!r}, {b!r}) names one link twice")
            key = (a, b) if index[a] < index[b] else (b, a)
            disabled.setdefault(key, "user")
        return CollisionMatrix(self.links, disabled, self.samples, self.counts)

    def as_dict(self) -> dict:
        """``{"links", "disabled": [{"links": [a, b], "reason"}], "samples"}`` (pairs in ``links`` order)."""
        index = {name: i for i, name in enumerate(self.links)}
        rows = sorted(self.disabled.items(), key=lambda kv: (index[kv[0][0]], index[kv[0][1]]))
        return {"links": list(self.links), "disabled": [{"links": [a, b], "reason": r} for (a, b), r in rows],
                "samples": self.samples}

    def to_srdf(self, robot: str) -> str:
        """The matrix as an SRDF document of ``disable_collisions`` elements (MoveIt's reasons:
        ``Adjacent``, ``Always``, ``Never``, ``User``).

        >>> CollisionMatrix(("a", "b"), {("a", "b"): "adjacent"}, 10).to_srdf("r").splitlines()[2]
        '    <disable_collisions link1="a" link2="b" reason="Adjacent"/>'
        """
        lines = ['<?xml version="1.0" encoding="utf-8"?>', f"<robot name={quoteattr(robot)}>"]
        for row in self.as_dict()["disabled"]:
            a, b = row["links"]
            lines.append(f"    <disable_collisions link1={quoteattr(a)} link2={quoteattr(b)} "
                         f"reason={quoteattr(row['reason'].capitalize())}/>")
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
