"""Things derived from a model once and kept as long as the model lives (compiled forms,
the reference library's view of it).

They are kept in a private cache on the model object (``_derived``, in its ``__dict__``, like its
``cached_property`` values): the model's fields never change. A weak-key dictionary beside the
model cannot do it, because a derived value refers to its model (``PoEModel.model``): the
dictionary's strong reference to the value kept every model alive for ever (a server leaked every
uploaded and deleted model; found by ``tests/app/test_soak.py``). On the model, model -> cache ->
value -> model is a cycle the garbage collector frees with the model. The cache is not copied
or pickled (a copy or an unpickled model derives its own)."""

from __future__ import annotations

import threading
import weakref
from typing import Callable, Generic, TypeVar

from .robot import RobotModel

T = TypeVar("T")


class PerModel(Generic[T]):
    """``build(model)``, computed once per model object (thread-safe) and dropped with the model.

    >>> from kinematics.io import parse_urdf
    >>> links = PerModel(lambda model: len(model.links))
    >>> model = parse_urdf('<robot name="r"><link name="a"/></robot>')
    >>> links(model), links(model) is links(model)
    (1, True)
    """

    def __init__(self, build: Callable[[RobotModel], T]):
        self._build = build
        # re-entrant: a build may ask for another model's value (the engine of a model on a floating
        # root compiles its sub-tree's model through the same cache)
        self._lock = threading.RLock()
        #: the models holding a value now (weak: monitoring only, never keeps a model alive)
        self._holders: "weakref.WeakSet[RobotModel]" = weakref.WeakSet()
        #: how many values were built (a count for monitoring; the values of dropped models included)
        self.built = 0

    def __call__(self, model: RobotModel) -> T:
        cache = model.__dict__.get("_derived")
        if cache is not None and cache.owner is model:  # (a shallow copy of a model shares its __dict__ values)
            value = cache.get(self, _MISSING)
            if value is not _MISSING:
                return value
        with self._lock:
            with _CACHE_LOCK:
                cache = model.__dict__.get("_derived")
                if cache is None or cache.owner is not model:
                    cache = _Cache()
                    cache.owner = model
                    object.__setattr__(model, "_derived", cache)  # a frozen dataclass: its fields stay as they are
            value = cache.get(self, _MISSING)
            if value is _MISSING:
                value = self._build(model)
                cache[self] = value
                self._holders.add(model)
                self.built += 1
        return value

    def __len__(self) -> int:
        """How many values are held now (one per live model)."""
        return len(self._holders)


_MISSING = object()
_CACHE_LOCK = threading.Lock()


class _Cache(dict):
    """The derived values of one model (``owner``), by :class:`PerModel`; pickled empty."""

    owner = None

    def __reduce__(self):
        return _Cache, ()
