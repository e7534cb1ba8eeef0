"""What ``pyproject.toml`` cannot say: the DH presets of the top-level ``models/`` directory are
the package ``kinematics.models`` of the wheel (``packages.find`` finds no package outside its
tree, and ``packages`` cannot be both a list and a find). Everything else is in ``pyproject.toml``.
"""

from setuptools import find_namespace_packages, setup

setup(
    packages=[*find_namespace_packages(include=["kinematics*", "app*"]), "kinematics.models"],
    package_dir={"kinematics.models": "models"},
)
