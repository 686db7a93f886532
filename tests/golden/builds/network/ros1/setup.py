"""The network Python package, for catkin_python_setup (not for pip)."""

from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import setup

PACKAGE = "network"

setup(
    **generate_distutils_setup(
        packages=[PACKAGE, f"{PACKAGE}.rmv_runtime", f"{PACKAGE}.rmv_host"],
        package_dir={"": "src"},
        package_data={PACKAGE: ["spec.json"]},
    )
)
