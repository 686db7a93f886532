"""What every node of a generated package reads first, with no ROS in it: the
resolved spec the package carries (`spec.json`, beside `rmv_host/`) and the
parameters that change it."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, MutableMapping
from importlib import resources
from pathlib import Path

from rmvdsl.runtime import spec as ir

TIME_SOURCES = ("receipt", "header")
# The Fast DDS profile beside spec.json (rmvdsl/targets/ament): faster announcements.
DISCOVERY_PROFILE = "fastdds_discovery.xml"
# What names a Fast DDS profile file, in Fast DDS 3 and 2.
PROFILE_VARIABLES = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")


def package() -> str:
    """The generated package this copy of the host lives in (`NAME.rmv_host`)."""
    return (__package__ or "").rpartition(".")[0]


def load_spec() -> ir.Spec:
    """The resolved spec the package was built from."""
    return ir.load(resources.files(package()).joinpath("spec.json").read_text(encoding="utf-8"))


def use_discovery_profile(environ: MutableMapping[str, str]) -> str | None:
    """Point Fast DDS at the package's profile (`environ` is os.environ, before the
    node's participant exists), unless the user chose a profile or another
    middleware, or Fast DDS would read a DEFAULT_FASTDDS_PROFILES.xml of the working
    folder; the profile's path, or None."""
    middleware = environ.get("RMW_IMPLEMENTATION", "") or "rmw_fastrtps_cpp"
    if not middleware.startswith("rmw_fastrtps") or any(environ.get(v) for v in PROFILE_VARIABLES):
        return None
    if Path("DEFAULT_FASTDDS_PROFILES.xml").exists():
        return None
    path = str(resources.files(package()).joinpath(DISCOVERY_PROFILE))
    environ["FASTDDS_DEFAULT_PROFILES_FILE"] = path
    return path


def with_time_sources(spec: ir.Spec, parameter: Callable[[str, str], str], node: str) -> ir.Spec:
    """The spec with each topic's time source as the node's parameter
    `time.<name>` says (`parameter(name, default)` reads one)."""
    topics = []
    for topic in spec.topics:
        source = parameter(f"time.{topic.name}", topic.time_source)
        if source not in TIME_SOURCES:
            raise SystemExit(
                f"{node}: parameter time.{topic.name} is {source!r}: "
                f"it must be one of {', '.join(TIME_SOURCES)}"
            )
        topics.append(dataclasses.replace(topic, time_source=source))
    return dataclasses.replace(spec, topics=tuple(topics))
