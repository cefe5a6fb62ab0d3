"""Command help that wraps as rich expects: prose paragraphs as one line each.

A command's help is its docstring, wrapped at the code's 100 columns; typer's rich help
keeps those line breaks after the first paragraph, so at 80 columns every wrapped line
ends in a short stub ("the setup" / "file written has ..."). :func:`reflow_tree` joins
the lines of each prose paragraph once, for the whole command tree, and leaves as they are
the paragraphs laid out on purpose: indented lines (examples, commands to type), lists,
and click's ``\\b`` (no rewrap) paragraphs.
"""

from __future__ import annotations

import inspect
from typing import Any


def reflow(text: str) -> str:
    """``text`` (a docstring) with each prose paragraph's lines joined by spaces."""
    paragraphs = inspect.cleandoc(text).split("\n\n")
    return "\n\n".join(p if _laid_out(p) else " ".join(line.strip() for line in
                                                         p.splitlines())
                       for p in paragraphs)


def _laid_out(paragraph: str) -> bool:
    """Whether a paragraph's line breaks mean something (examples, a list, ``\\b``)."""
    lines = paragraph.splitlines()
    return paragraph.startswith("\b") or any(
        line[:1].isspace() or line.lstrip().startswith(("- ", "* ", "$ ")) for line in lines)


def reflow_tree(command: Any) -> Any:
    """Reflow the help of ``command`` (a click command) and of every subcommand it holds
    already built (commands built on demand, like ``run KIND``, write their own); returns
    ``command``."""
    if getattr(command, "help", None):
        command.help = reflow(command.help)
    for sub in getattr(command, "commands", {}).values():
        reflow_tree(sub)
    return command


def plain_flags() -> None:
    """Show no type beside a flag (``--force``, ``--[no-]record``, ``--help``) in rich help:
    a flag takes no value, so ``<bool>`` there reads as if it did. Options with a value keep
    their type (``<int>``, ``<path>``). A no-op on typer versions that print no type."""
    from typer.core import TyperOption

    shown = getattr(TyperOption, "display_type_rich", None)
    if shown is None or getattr(shown, "plain_flags", False):
        return

    def display_type_rich(self: Any, ctx: Any) -> str | None:
        return None if getattr(self, "is_flag", False) else shown(self, ctx)

    display_type_rich.plain_flags = True  # type: ignore[attr-defined]
    TyperOption.display_type_rich = display_type_rich  # type: ignore[method-assign]
