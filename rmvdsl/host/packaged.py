"""What every node of a generated package reads first, with no ROS in it: the
resolved spec the package carries (`spec.json`, beside `rmv_host/`) and the
parameters that change it."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from importlib import resources

from rmvdsl.runtime import spec as ir

TIME_SOURCES = ("receipt", "header")


def package() -> str:
    """The generated package this copy of the host lives in (`NAME.rmv_host`)."""
    return (__package__ or "").rpartition(".")[0]


def load_spec() -> ir.Spec:
    """The resolved spec the package was built from."""
    return ir.load(resources.files(package()).joinpath("spec.json").read_text(encoding="utf-8"))


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
