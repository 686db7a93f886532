"""YAML read safely and bounded, each mapping remembering where it was written
(file:line:column for every note of the import)."""

from __future__ import annotations

from typing import Any

import yaml

from rmvdsl.lang.errors import UsageError
from rmvdsl.lang.files import read_text
from rmvdsl.runtime.wording import counted


class Located(dict[str, Any]):
    """A YAML mapping that remembers where it and each of its keys stand."""

    path: str = ""
    line: int = 0
    column: int = 0
    key_marks: dict[str, tuple[int, int]]

    def where(self, key: str | None = None) -> str:
        line, column = (
            self.key_marks.get(key, (self.line, self.column)) if key else (self.line, self.column)
        )
        return f"{self.path}:{line}:{column}"


def _loader_for(path: str) -> type[yaml.SafeLoader]:
    class Loader(yaml.SafeLoader):
        pass

    def construct_mapping(loader: yaml.SafeLoader, node: yaml.MappingNode) -> Located:
        raw = loader.construct_mapping(node, deep=True)
        mapping = Located({str(key): value for key, value in raw.items()})
        mapping.path = path
        mapping.line, mapping.column = node.start_mark.line + 1, node.start_mark.column + 1
        mapping.key_marks = {
            str(key.value): (key.start_mark.line + 1, key.start_mark.column + 1)
            for key, _ in node.value
        }
        return mapping

    Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, construct_mapping)
    return Loader


# YAML's aliases can multiply a small file into billions of values (nine levels of
# `&a [*a, *a, ...]`): the nodes are counted as the aliases are followed, before
# anything is built, and a document past this size is refused.
MAX_NODES = 100_000


def load_yaml(path: str) -> Any:
    text = read_text(path)
    try:
        loader = _loader_for(path)(text)
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            _check_size(node, path)
            return loader.construct_document(node)
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"{path}:{mark.line + 1}:{mark.column + 1}" if mark else path
        problem = exc.problem or exc.context or "invalid YAML"
        raise UsageError(f"{where}: {problem}") from None
    except yaml.YAMLError as exc:
        raise UsageError(f"{path}: invalid YAML: {exc}") from None


def _check_size(root: yaml.Node, path: str) -> None:
    count = 0
    stack: list[yaml.Node] = [root]
    while stack:
        node = stack.pop()
        count += 1
        if count > MAX_NODES:
            mark = node.start_mark
            raise UsageError(
                f"{path}:{mark.line + 1}:{mark.column + 1}: the document expands to more than "
                f"{counted(MAX_NODES, 'value', grouped=True)} "
                "(aliases repeated inside aliases): refused"
            )
        if isinstance(node, yaml.SequenceNode):
            stack.extend(node.value)
        elif isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                stack += [key, value]
