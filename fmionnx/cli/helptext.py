"""How ``--help`` reads: no placeholder for a plain flag, paragraphs wrapped to the terminal.

typer renders every option with a type placeholder: ``--quiet -q <bool>`` tells the reader a
value is expected where none is. A flag is shown without one here, as click's own help shows
flags. And with ``rich_markup_mode="rich"`` typer keeps a docstring's line breaks: a
docstring wrapped at 100 columns, shown in 80, came out as ragged lines ("... names the folder.
A fault" and the rest of the sentence on the next line). :func:`unwrapped` joins the lines of
each prose paragraph so that the terminal's width decides where a sentence breaks; indented
paragraphs (the examples of an epilog) and list items keep their lines.

:func:`tidy` applies both to an application once its commands are registered; the command and
group classes apply the flag rule to parameters typer adds itself (``--help``).
"""

from __future__ import annotations

import inspect
import re
from typing import TYPE_CHECKING

import typer
from typer.core import TyperCommand, TyperGroup, TyperOption
from typer.models import DefaultPlaceholder

if TYPE_CHECKING:  # typer's own copy of click (typer >= 0.20 vendors it)
    from typer._click.core import Context, Parameter

#: A line that keeps its own line: a list item, preformatted (indented) text, or typer's
#: ``\b`` (no rewrapping) marker.
_OWN_LINE = re.compile(r"^(\s|[-*•] |\d+\. |\x08)")


class _FlagOption(TyperOption):
    """A typer option that takes no value: its help shows no type placeholder."""

    def display_type_rich(self, ctx: Context) -> str | None:
        """None: nothing to show (typer shows ``<bool>``)."""
        return None


def plain_flags(params: list[Parameter]) -> list[Parameter]:
    """``params`` with every flag (an option that takes no value) shown without a type.

    typer makes the options itself; a flag's class is switched to :class:`_FlagOption`,
    which differs only in what the help shows.
    """
    for param in params:
        if type(param) is TyperOption and param.is_flag:
            param.__class__ = _FlagOption
    return params


class PlainFlagsCommand(TyperCommand):
    """A command whose help shows no ``<bool>`` after its flags."""

    def get_params(self, ctx: Context) -> list[Parameter]:
        """The parameters, flags with an empty placeholder."""
        return plain_flags(super().get_params(ctx))


class PlainFlagsGroup(TyperGroup):
    """A command group whose help shows no ``<bool>`` after its flags."""

    def get_params(self, ctx: Context) -> list[Parameter]:
        """The parameters, flags with an empty placeholder."""
        return plain_flags(super().get_params(ctx))


def unwrapped(text: str) -> str:
    """``text`` with the line breaks inside each prose paragraph replaced by spaces.

    Paragraphs are separated by blank lines; a paragraph whose first line is indented (an
    example) and a line that starts a list item keep their breaks.
    """
    paragraphs = []
    for paragraph in inspect.cleandoc(text).split("\n\n"):
        if paragraph[:1].isspace():
            paragraphs.append(paragraph)
            continue
        lines: list[str] = []
        for line in paragraph.split("\n"):
            if lines and not _OWN_LINE.match(line):
                lines[-1] = f"{lines[-1].rstrip()} {line.strip()}"
            else:
                lines.append(line.rstrip())
        paragraphs.append("\n".join(lines))
    return "\n\n".join(paragraphs)


def tidy(app: typer.Typer) -> None:
    """Give every command (and group) of ``app`` the classes above and unwrapped help texts.

    Called once, after the command modules registered their commands; a command that names a
    class of its own keeps it.
    """
    for info in app.registered_commands:
        if _default(info.cls, TyperCommand):
            info.cls = PlainFlagsCommand
        doc = info.help if info.help is not None else info.callback and info.callback.__doc__
        if doc:
            info.help = unwrapped(doc)
        if info.epilog:
            info.epilog = unwrapped(info.epilog)
    for group in app.registered_groups:
        if _default(group.cls, TyperGroup):
            group.cls = PlainFlagsGroup
        if group.typer_instance is not None:
            if _default(group.typer_instance.info.cls, TyperGroup):
                group.typer_instance.info.cls = PlainFlagsGroup
            tidy(group.typer_instance)


def _default(cls: object, plain: type) -> bool:
    """Whether ``cls`` is typer's default class (unset, a placeholder, or ``plain`` itself)."""
    return cls is None or cls is plain or isinstance(cls, DefaultPlaceholder)
