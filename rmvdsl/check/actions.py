"""Actions (names stage): each action's arguments against its signature, and ROS
names wherever a spec writes one."""

from __future__ import annotations

from collections.abc import Iterable

from rmvdsl.check.rosnames import name_problem, suggest_name
from rmvdsl.grammar import ast
from rmvdsl.lang import builtins
from rmvdsl.lang.diagnostics import Diagnostic, did_you_mean, error

ACTIONS = builtins.ACTIONS
LOG_LEVELS = builtins.LOG_LEVELS


_ACTION_EXAMPLES = {
    "topic": '"/rmv/alerts"',
    "url": '"http://127.0.0.1:9000/alerts"',
    "command": '"/usr/local/bin/notify.sh"',
    "address": '"127.0.0.1:5678"',
}


class ActionChecks:
    """The names stage's checks of actions and ROS names (a part of NameChecker)."""

    diagnostics: list[Diagnostic]

    def report(self, diagnostic: Diagnostic) -> None:
        self.diagnostics.append(diagnostic)

    def check_ros_name(
        self, literal: ast.StringLit, what: str, code: str, patterns: bool = False
    ) -> None:
        problem = name_problem(literal.value, what, patterns)
        if problem:
            self.report(
                error(
                    code,
                    f"invalid ROS {what} name",
                    literal.span,
                    label=problem,
                    help=f'did you mean "{suggest_name(literal.value)}"?',
                )
            )

    def check_actions(self, actions: Iterable[ast.Action]) -> None:
        for action in actions:
            self.check_action(action)

    def check_action(self, action: ast.Action) -> None:
        kind = action.kind.name
        signature = ACTIONS.get(kind)
        if signature is None:
            self.report(
                error(
                    "RMV216",
                    f"unknown action `{kind}`",
                    action.kind.span,
                    label="expected " + ", ".join(ACTIONS),
                    help=did_you_mean(kind, ACTIONS),
                )
            )
            return
        required = signature.positional[: signature.required]
        optional = signature.positional[signature.required :]
        keywords = signature.keywords
        positional = [a for a in action.args if a.key is None]
        named = {a.key.name: a for a in action.args if a.key is not None}
        for key, arg in named.items():
            if key not in keywords:
                self.bad_action_arg(
                    arg, f"`{kind}` has no argument `{key}`", did_you_mean(key, keywords)
                )
        if len(positional) > len(required) + len(optional):
            self.bad_action_arg(
                positional[len(required) + len(optional)],
                f"`{kind}` takes at most {len(required) + len(optional)} positional arguments",
                None,
            )
        given = {*([*required, *optional][: len(positional)]), *named}
        for name in required:
            if name not in given:
                self.report(
                    error(
                        "RMV217",
                        f"`{kind}` needs its `{name}`",
                        action.span,
                        label=f"no `{name}` given",
                        help=f"write e.g. `action {kind}({_ACTION_EXAMPLES[name]})`",
                    )
                )
        self.check_action_values(signature, positional, named)

    def check_action_values(
        self, signature: builtins.ActionSpec, positional: list[ast.Arg], named: dict[str, ast.Arg]
    ) -> None:
        kind = signature.name
        values = dict(zip(signature.positional, positional, strict=False)) | named
        for name, arg in values.items():
            value = arg.value
            parameter = signature.parameters.get(name)
            if parameter is None:
                continue  # not an argument of this action: reported above
            if parameter.kind == "level":
                if not (isinstance(value, ast.NameValue) and value.ident.name in LOG_LEVELS):
                    found = value.ident.name if isinstance(value, ast.NameValue) else ""
                    self.bad_action_arg(
                        arg,
                        "`level` is one of " + ", ".join(LOG_LEVELS),
                        did_you_mean(found, LOG_LEVELS) if found else None,
                    )
            elif parameter.kind == "time":
                if not isinstance(value, ast.TimeLit):
                    self.bad_action_arg(arg, f"`{name}` is a time such as `2s`", None)
            elif parameter.kind == "strings" and isinstance(value, ast.ListValue):
                if not all(isinstance(item, ast.StringLit) for item in value.items):
                    self.bad_action_arg(arg, f"`{name}` of `{kind}` is a list of strings", None)
            elif not isinstance(value, ast.StringLit):
                self.bad_action_arg(arg, f"`{name}` of `{kind}` is a string", None)
            elif parameter.kind == "topic":
                self.check_ros_name(value, "topic", "RMV204")

    def bad_action_arg(self, arg: ast.Arg, message: str, hint: str | None) -> None:
        self.report(error("RMV217", message, arg.span, label="invalid argument", help=hint))
