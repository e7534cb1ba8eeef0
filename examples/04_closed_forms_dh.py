"""Closed forms of a DH table: the SCARA with symbolic lengths, checked against numeric FK.

The table's entries may be names (a1, d4) or expressions (pi/2); the derivation (sympy, in a
worker process) gives T(q) = A_1 ... A_n, the Jacobians and task vectors r(q), J_r = dr/dq.

Run: python examples/04_closed_forms_dh.py
"""

import numpy as np
import sympy as sp

import kinematics
from kinematics import api

# De Luca's SCARA (RRPR), standard DH, lengths left as symbols (d4 < 0)
TABLE = {"convention": "standard", "joints": [
    {"type": "R", "a": "a1", "alpha": 0, "d": "d1", "theta": 0},
    {"type": "R", "a": "a2", "alpha": 0, "d": 0, "theta": 0},
    {"type": "P", "a": 0, "alpha": 0, "d": 0, "theta": 0},
    {"type": "R", "a": 0, "alpha": "pi", "d": "d4", "theta": 0},
]}


def main() -> None:
    answer = api.symbolic_dh(TABLE, what=["transforms", "task"], representation="scara", fmt="text")
    forms = answer.forms
    print("parameters:", answer.output["parameters"])
    print("position of the tool:")
    for row in forms.T[:3, 3]:
        print("   ", row)
    print("r = (px, py, pz, alpha_z):", list(forms.task.r))
    print("J_r = dr/dq:", forms.task.J_r.tolist())
    latex = api.symbolic_dh(TABLE, fmt="latex").output["T"]  # the textbooks' c_{12}, s_{124}
    print("T in LaTeX:", latex[:72], "...")

    # the bundled `scara` model is this table with a1 = 0.325, a2 = 0.275, d1 = 0.4, d4 = -0.1
    values = {"a1": 0.325, "a2": 0.275, "d1": 0.4, "d4": -0.1}
    subs = {s: values[s.name] for s in forms.T.free_symbols if s.name in values}
    q_syms = sorted((s for s in forms.T.free_symbols if s.name not in values), key=lambda s: s.name)
    T_of_q = sp.lambdify(q_syms, forms.T.subs(subs), "numpy")

    scara = kinematics.default_catalogue().get("scara")
    Q = scara.sample_configurations(100, np.random.default_rng(0))
    T_numeric = kinematics.fk(scara, Q, links=["tool"]).poses[:, 0]
    worst = max(np.abs(np.array(T_of_q(*q), dtype=float) - T).max() for q, T in zip(Q, T_numeric))
    print(f"closed form vs compiled FK over 100 configurations: {worst:.1e}")
    assert worst < 1e-12


if __name__ == "__main__":  # the derivation runs in a worker process (multiprocessing)
    main()
