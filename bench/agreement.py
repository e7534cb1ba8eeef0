"""Worst deviation of the compiled kernels from the reference implementation, over the
whole catalogue: FK of every link and the three Jacobians of every leaf link.

    python -m bench.agreement [--samples N]

``tests/kinematics/engine/test_kernels.py`` asserts the same agreement (≤ 1e-12); this prints the figures.
"""

from __future__ import annotations

import argparse
import zlib

import numpy as np

from kinematics import REFERENCES, compile_model, default_catalogue
from kinematics.errors import URDFError


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=100, help="configurations per model (default 100)")
    args = parser.parse_args()
    cat = default_catalogue()
    worst_fk = worst_j = 0.0
    models = 0
    for mid in cat.ids():
        try:
            model = cat.get(mid)
        except URDFError:  # a model the parser refuses
            continue
        models += 1
        poe = compile_model(model)
        Q = model.sample_configurations(args.samples, np.random.default_rng(zlib.crc32(mid.encode())))
        worst_fk = max(worst_fk, float(np.abs(poe.fk(Q) - poe.fk_reference(Q)).max(initial=0.0)))
        for leaf in model.leaf_links:
            for ref in REFERENCES:
                dev = np.abs(poe.jacobian(Q, leaf, ref) - poe.jacobian_reference(Q, leaf, ref))
                worst_j = max(worst_j, float(dev.max(initial=0.0)))
    print(f"kernels vs reference, {models} models x {args.samples} configurations: "
          f"FK worst {worst_fk:.2e}, Jacobians worst {worst_j:.2e}")


if __name__ == "__main__":
    main()
