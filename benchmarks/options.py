"""One option vocabulary for every ``mpc-bench`` command.

A list of names is always taken by the same plural option, whichever command takes it:
:data:`LIST_OPTIONS`. A command that takes one name only (``qp-replay`` records one
scenario) keeps the plural name and says so when given more. The singular spellings some
commands used before still work, hidden from ``--help``, with a note on stderr.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

#: The list options, by the plural name every command uses, and the older spellings
#: (hidden aliases) that commands accepted before.
LIST_OPTIONS: dict[str, tuple[str, ...]] = {
    "--layouts": ("--layout",),
    "--trajectories": (),  # --trajectory is run's FILE option, not a spelling of this
    "--headings": ("--heading",),
    "--speeds": ("--speed",),
    "--controllers": ("--controller",),
    "--modes": ("--mode",),
    "--solvers": ("--solver",),
    "--sections": ("--section",),
    "--kinds": ("--kind",),
    "--horizons": (),  # --horizon is the MPC's horizon, a number
    "--plants": (),  # --plant is run's one plant
}


class _OldSpelling(argparse.Action):
    """An older spelling of an option: stores into its ``dest``, with a note on stderr."""

    def __init__(self, option_strings: Sequence[str], dest: str, current: str = "",
                 **kwargs: Any) -> None:
        super().__init__(option_strings, dest, **kwargs)
        self.current = current

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        print(f"{parser.prog}: note: {option_string} is now spelled {self.current}",
              file=sys.stderr)
        setattr(namespace, self.dest, values)


def add_list_option(parser: argparse.ArgumentParser, flag: str, *,
                    old: Sequence[str] | None = None, **kwargs: Any) -> argparse.Action:
    """``parser.add_argument(flag, **kwargs)`` for a list option of :data:`LIST_OPTIONS`,
    with its older spellings (default: the vocabulary's) as hidden aliases."""
    if flag not in LIST_OPTIONS:
        raise ValueError(f"{flag} is not a list option; known: {', '.join(LIST_OPTIONS)}")
    action = parser.add_argument(flag, **kwargs)
    same: dict[str, Any] = {"type": action.type} if action.type is not None else {}
    for spelling in LIST_OPTIONS[flag] if old is None else old:
        parser.add_argument(spelling, dest=action.dest, action=_OldSpelling, current=flag,
                            choices=action.choices, default=argparse.SUPPRESS,
                            help=argparse.SUPPRESS, **same)
    return action


__all__ = ["LIST_OPTIONS", "add_list_option"]
