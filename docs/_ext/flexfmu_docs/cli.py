"""The command-line reference, walked from ``flexfmu.cli.build_parser()``: per command and sub-command its
usage, description and every argument with its help, grouped as ``--help`` groups them."""
from __future__ import annotations

import argparse

from .markdown import block, code, escape


def _subcommands(parser: argparse.ArgumentParser):
    """(name, one-line help, parser) of each sub-command of ``parser``, in the order they were added."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help for choice in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, helps.get(name) or "", sub


def _arguments(parser: argparse.ArgumentParser, formatter: argparse.HelpFormatter) -> list[str]:
    lines = []
    for group in parser._action_groups:
        actions = [a for a in group._group_actions
                   if a.help is not argparse.SUPPRESS and not isinstance(a, argparse._SubParsersAction)]
        if not actions:
            continue
        lines += [f"**{escape(group.title)}**", ""]
        if group.description:
            lines += [escape(group.description), ""]
        for action in actions:
            invocation = formatter._format_action_invocation(action)
            help_text = formatter._expand_help(action) if action.help else ""
            lines.append(f"- {code(invocation)}" + (f": {escape(help_text)}" if help_text else ""))
        lines.append("")
    return lines


def _section(parser: argparse.ArgumentParser, path: str, summary: str, level: int) -> list[str]:
    formatter = parser._get_formatter()
    lines = [f"{'#' * level} {code(path)}", ""]
    if summary:
        lines += [escape(summary[0].upper() + summary[1:]) + ".", ""]
    lines += [block(parser.format_usage().strip()), ""]
    if parser.description and parser.description != summary:
        lines += [escape(parser.description), ""]
    lines += _arguments(parser, formatter)
    subs = list(_subcommands(parser))
    if subs:
        lines += ["**sub-commands**", ""]
        lines += [f"- {code(name)}: {escape(text)}" for name, text, _ in subs]
        lines.append("")
    for name, text, sub in subs:
        lines += _section(sub, f"{path} {name}", text, level + 1)
    return lines


def render(parser: argparse.ArgumentParser | None = None, level: int = 2) -> str:
    """Markdown for ``parser`` (default: flexfmu's) and all its sub-commands, headings from ``level`` on."""
    if parser is None:
        from flexfmu.cli import build_parser
        parser = build_parser()
    return "\n".join(_section(parser, parser.prog, "", level))
