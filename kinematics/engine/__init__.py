"""The numeric engine: a model compiled to screws and home poses, the numba kernels that
evaluate its product of exponentials over batches, their plans, and result buffers."""

from .poe import PoEModel, compile_model

__all__ = ["PoEModel", "compile_model"]
