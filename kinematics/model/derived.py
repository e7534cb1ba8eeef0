"""Things derived from a model once and kept as long as the model lives (compiled forms,
the reference library's view of it): the model itself stays immutable, nothing is hung on it."""

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
        self._values: "weakref.WeakKeyDictionary[RobotModel, T]" = weakref.WeakKeyDictionary()
        # re-entrant: a build may ask for another model's value (the engine of a model on a floating
        # root compiles its sub-tree's model through the same cache)
        self._lock = threading.RLock()
        #: how many values were built (a count for monitoring; the values of dropped models included)
        self.built = 0

    def __call__(self, model: RobotModel) -> T:
        value = self._values.get(model)
        if value is None:
            with self._lock:
                value = self._values.get(model)
                if value is None:
                    value = self._build(model)
                    self._values[model] = value
                    self.built += 1
        return value

    def __len__(self) -> int:
        """How many values are held now (one per live model)."""
        return len(self._values)
