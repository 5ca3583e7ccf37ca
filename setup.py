"""The package list, derived: every folder of ``bodyvib/`` and of each folder that
pyproject.toml's ``[tool.setuptools.package-dir]`` maps into it (``vehicle/`` installs as
``bodyvib.vehicle``, ``fmu_src/`` as ``bodyvib.fmu_src``). Everything else is in
pyproject.toml; a new subpackage needs no entry anywhere.
"""

import os

from setuptools import find_namespace_packages, setup
from setuptools.config.pyprojecttoml import load_file

HERE = os.path.dirname(os.path.abspath(__file__))
#: Installed package -> its folder in the repository (pyproject.toml's package-dir).
PACKAGE_DIR = load_file(os.path.join(HERE, "pyproject.toml"))["tool"]["setuptools"]["package-dir"]


def packages():
    """The installed names of ``bodyvib`` and of every mapped folder, with their subfolders."""
    skip = ["*__pycache__*"]
    found = find_namespace_packages(HERE, include=["bodyvib", "bodyvib.*"], exclude=skip)
    for name, folder in PACKAGE_DIR.items():
        found.append(name)
        found += [
            f"{name}.{p}" for p in find_namespace_packages(os.path.join(HERE, folder), exclude=skip)
        ]
    return sorted(set(found))


if __name__ == "__main__":  # as setuptools runs it; tests/test_wheel.py imports it
    setup(packages=packages())
