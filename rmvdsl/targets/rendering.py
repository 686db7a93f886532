"""The one way a target renders its templates: jinja2 over package data, strict
about undefined names, no HTML escaping (each target quotes with its own filters,
one function per target language)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import jinja2


def template_environment(
    packages: tuple[str, ...], filters: Mapping[str, Callable[[str], str]]
) -> jinja2.Environment:
    """The `templates` folder of each of `packages`, searched in order, with the
    target's quoting `filters`."""
    loaders = [jinja2.PackageLoader(p, "templates") for p in packages]
    env = jinja2.Environment(
        loader=jinja2.ChoiceLoader(loaders),
        autoescape=False,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        undefined=jinja2.StrictUndefined,
    )
    env.filters.update(filters)
    return env
