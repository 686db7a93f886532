"""The carla_abs package: Runtime monitor."""

from setuptools import setup

PACKAGE = "carla_abs"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=[PACKAGE, f"{PACKAGE}.rmv_runtime", f"{PACKAGE}.rmv_host"],
    package_data={PACKAGE: ["spec.json", "fastdds_discovery.xml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml", "README.md"]),
        (f"share/{PACKAGE}/launch", ["launch/monitor.launch.py"]),
        (f"share/{PACKAGE}/config", ["config/params.yaml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description="Runtime monitor",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            f"monitor = {PACKAGE}.monitor_node:main",
            f"intrusion = {PACKAGE}.intrusion_node:main",
        ],
    },
)
