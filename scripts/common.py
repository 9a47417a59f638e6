"""The settings options of the subcommands that ground skills, generated from :class:`RecentSettings`.

Every field of the tree is one ``--dotted.path`` option, the same path ``lerobot-eval`` takes
under ``--policy.`` (``--infiller.type=rule`` here is ``--policy.infiller.type=rule`` there). A choice
field (``infiller``, ``method``) gives ``--<field>.type`` with its registered names, and one option
per field of any of its choices; draccus decodes the values into the typed tree.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Iterator
from typing import get_type_hints

import draccus
from draccus.wrappers.docstring import get_attribute_docstring

from lerobot_policy_recent.evaluation import methods as _methods  # noqa: F401  (registers ablations, baselines)
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.settings import RecentSettings, parse_settings

DEST = "settings."  # argparse dest prefix of the generated options


@dataclasses.dataclass(frozen=True)
class SettingsOption:
    path: str  # infiller.n_threads
    help: str
    choices: tuple[str, ...] | None = None


def settings_options(
    cls: type = RecentSettings, prefix: str = "", skip: tuple[str, ...] = ()
) -> Iterator[SettingsOption]:
    """One option per leaf of the tree under ``cls`` (fields named in ``skip`` left out)."""
    types = get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        kind, path = types[f.name], prefix + f.name
        doc = _doc(cls, f.name)
        if isinstance(kind, type) and issubclass(kind, draccus.ChoiceRegistry):
            choices = kind.get_known_choices()
            yield SettingsOption(f"{path}.type", f"{doc} (default: {kind.default_choice_name()})", tuple(choices))
            owners: dict[str, list[str]] = {}
            for name, choice in choices.items():
                for sub in dataclasses.fields(choice):
                    owners.setdefault(sub.name, []).append(name)
            for sub, names in owners.items():
                owner = choices[names[0]]
                yield SettingsOption(f"{path}.{sub}", f"[{_owners(names, list(choices))}] {_doc(owner, sub)}")
        elif dataclasses.is_dataclass(kind):  # a subtree of plain fields (``--skill_budget.step_seconds``)
            yield from settings_options(kind, f"{path}.")
        else:
            yield SettingsOption(path, f"{doc} (default: {f.default})")


def _owners(names: list[str], choices: list[str]) -> str:
    """Which choices have a field: ``llamacpp, transformers``, or ``all but cap, repair, agentless``."""
    others = [c for c in choices if c not in names]
    if not others:
        return "all"
    return f"all but {', '.join(others)}" if len(others) < len(names) else ", ".join(names)


def _doc(cls: type, name: str) -> str:
    for klass in cls.__mro__:  # the nearest class that declares the field documents it
        if dataclasses.is_dataclass(klass) and name in getattr(klass, "__annotations__", {}):
            doc = get_attribute_docstring(klass, name)
            return (doc.comment_inline or doc.comment_above or doc.docstring_below or "").strip()
    return ""


def at_least(low: int):
    """An argparse type: an integer >= ``low`` (argparse names the option and the value when it is not)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"{value} is below {low}: it must be an integer >= {low}")
        return value

    parse.__name__ = f"integer >= {low}"
    return parse


def add_settings_arguments(parser: argparse.ArgumentParser, *, with_method: bool = True) -> None:
    """The tree's options (without ``method.*`` where the command takes methods by name: ``recent bench``)."""
    group = parser.add_argument_group("settings (the same tree as lerobot-eval's --policy.*)")
    for option in settings_options(skip=() if with_method else ("method",)):
        group.add_argument(
            f"--{option.path}",
            dest=DEST + option.path,
            default=argparse.SUPPRESS,
            choices=option.choices,
            metavar=None if option.choices else "VALUE",
            help=option.help.replace("%", "%%"),
        )


def settings_from_args(args: argparse.Namespace) -> RecentSettings:
    """The typed tree from the options given (the rest keep their defaults)."""
    given = {k.removeprefix(DEST): v for k, v in vars(args).items() if k.startswith(DEST)}
    return parse_settings([f"--{path}={value}" for path, value in given.items()])


def agent_from_args(args: argparse.Namespace) -> RecentAgent:
    return RecentAgent(settings_from_args(args))
