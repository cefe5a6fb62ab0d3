"""The command-line reference, docs/cli.md, generated so that it cannot drift from the code.

``python -m inkmotion.cli.reference > docs/cli.md`` (``make docs``) writes it; a test
fails when the file in the repository differs from what this module prints.

Two sources, neither of them a terminal's help output (which wraps with the terminal):

- the job kinds (``inkmotion run KIND``, ``inkmotion submit KIND``) from their own
  declarations: name, description, queue, inputs (:class:`inkmotion.jobs.kind.InputSpec`),
  parameters (:func:`inkmotion.jobs.params.describe`, with bounds, choices and the defaults
  of older spec versions), each plugin's ``Options``, and examples;
- every other command from the command tree of ``inkmotion.cli.main:app``: name, help,
  arguments and options with their defaults.

Only the project's own plugins appear (those whose entry point belongs to the ``inkmotion``
distribution): a third-party package installed beside it adds kinds and plugin options to
the live command line, never to this page, so the page is the same in every environment.
"""

from __future__ import annotations

import dataclasses
import inspect
import re
import sys
from pathlib import Path
from typing import Any

from inkmotion.jobs.params import ParamInfo, PluginChoice, default_for, describe, number_text
from inkmotion.jobs.spec import SPEC_VERSION

#: the distribution whose plugins the reference lists
DISTRIBUTION = "inkmotion"
#: command groups whose subcommands are the job kinds (documented from the declarations)
KIND_GROUPS = ("run", "submit")
_TYPE_NAMES = {int: "integer", float: "number", str: "text", bool: "flag", Path: "path",
               PluginChoice: "plugin"}


# --- which plugins are the project's own ----------------------------------------------------
def own_plugins() -> dict[str, dict[str, Any]]:
    """The project's own plugin objects by plugin kind and name (entry points of the
    :data:`DISTRIBUTION` distribution only; broken and disabled ones left out)."""
    from inkmotion.plugin_host import host
    from inkmotion.plugin_host.hookspecs import KIND_HOOKS

    h = host()
    own = {(r.kind, r.name) for r in h.table()
           if r.error is None and r.origin.split(" ", 1)[0] == DISTRIBUTION}
    return {kind: {name: obj for name, obj in sorted(h.plugins(kind).items())
                   if (kind, name) in own}
            for kind in KIND_HOOKS}


# --- text ------------------------------------------------------------------------------------
def _escape(text: str, table: bool = False) -> str:
    """``text`` as Markdown prose: rich's ``\\[`` unescaped, HTML-like and emphasis characters
    escaped outside `code` spans (and ``|`` inside a table cell)."""
    text = text.replace("\\[", "[")
    parts = re.split(r"(`[^`]*`)", text)
    for i in range(0, len(parts), 2):
        part = parts[i].replace("<", "&lt;").replace(">", "&gt;").replace("*", "\\*")
        parts[i] = part.replace("|", "\\|") if table else part
    if table:
        parts = [p.replace("|", "\\|") if p.startswith("`") else p for p in parts]
    return "".join(parts).replace("\n", " ")


def help_markdown(text: str | None) -> list[str]:
    """A command's help as Markdown lines: prose paragraphs joined onto one line each, and
    indented paragraphs (examples) gathered into code blocks."""
    if not text:
        return []
    text = inspect.cleandoc(text).replace("\\[", "[")
    out: list[str] = []
    code: list[str] = []

    def close_code() -> None:
        if code:
            out.extend(["```bash", *code, "```", ""])
            code.clear()

    for para in re.split(r"\n\s*\n", text):
        lines = [line for line in para.splitlines() if line.strip() and line.strip() != "\b"]
        if not lines:
            continue
        if all(line.startswith((" ", "\t")) for line in lines):
            code.extend(line.strip() for line in lines)
            continue
        close_code()
        out.extend([_escape(" ".join(line.strip() for line in lines)), ""])
    close_code()
    return out


def _value(value: Any) -> str:
    """A default as a table cell."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, PluginChoice):
        return f"`{value.name}`"
    if isinstance(value, list):
        return ", ".join(_value(v) for v in value) or "none"
    if isinstance(value, float):
        return f"`{value:g}`"
    if value == "":
        return '`""`'
    return f"`{value}`"


def _range(info: ParamInfo) -> str:
    if info.choices:
        return ", ".join(f"`{c}`" for c in info.choices)
    lo, hi = info.minimum, info.maximum
    if lo is not None and hi is not None:
        return f"{number_text(lo)} … {number_text(hi)}"
    if lo is not None:
        return f"≥ {number_text(lo)}"
    if hi is not None:
        return f"≤ {number_text(hi)}"
    return ""


def older_defaults(cls: type, name: str) -> str:
    """The defaults field ``name`` of ``cls`` had in older spec versions, where they differ
    from today's, e.g. ``v1–2: 300`` (:func:`inkmotion.jobs.params.default_for`)."""
    f = {f.name: f for f in dataclasses.fields(cls)}[name]
    current = next(i.default for i in describe(cls) if i.name == name)
    runs: list[tuple[int, int, Any]] = []  # (first version, last version, default)
    for version in range(1, SPEC_VERSION):
        older, value = default_for(f, max(version, 2))  # a version-1 spec loads as version 2
        value = value if older else current
        if runs and runs[-1][2] == value:
            runs[-1] = (runs[-1][0], version, value)
        else:
            runs.append((version, version, value))
    cells = [f"v{a}{'' if a == b else f'–{b}'}: {_value(v)}" for a, b, v in runs
             if v != current]
    return "; ".join(cells)


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    if not rows:
        return []
    keep = [i for i, _ in enumerate(header) if i < 2 or any(r[i] for r in rows)]
    lines = ["| " + " | ".join(header[i] for i in keep) + " |",
             "|" + "|".join("---" for _ in keep) + "|"]
    lines += ["| " + " | ".join(r[i] for i in keep) + " |" for r in rows]
    return [*lines, ""]


# --- the job kinds ---------------------------------------------------------------------------
def _param_rows(cls: type, key: str, plugins: dict[str, dict[str, Any]]) -> list[list[str]]:
    """Table rows of the parameters of ``cls`` (a kind's Params), job.json keys under ``key``."""
    rows = []
    for info in describe(cls):
        allowed = _range(info)
        kind_type = _TYPE_NAMES.get(info.type, info.type.__name__)
        if info.plugin_kind is not None:
            names = ", ".join(f"`{n}`" for n in plugins.get(info.plugin_kind, {}))
            allowed = f"{info.plugin_kind}: {names}"
            kind_type = f"{info.plugin_kind} plugin" + (" (repeatable)" if info.many else "")
        option = (f"`--{info.option[2:]}` / `--no-{info.option[2:]}`" if info.type is bool
                  else f"`{info.option}`")
        if info.optional and info.default is None and info.plugin_kind is None:
            default = "none"
        else:
            default = _value(info.default) or "none"
        rows.append([option, f"`{key}{info.name}`", kind_type, default, allowed,
                     _escape(info.help, table=True), older_defaults(cls, info.name)])
    return rows


def _plugin_option_rows(kind: Any, plugins: dict[str, dict[str, Any]]) -> list[list[str]]:
    """Rows of every option of every own plugin the kind's parameters can choose, with the
    command-line flag the kind's commands give it."""
    from inkmotion.cli.kind_commands import plugin_options

    flags = {(name, opt.name): opt.option for _, (_, name, opt) in plugin_options(kind).items()}
    rows = []
    for info in describe(kind.Params):
        if info.plugin_kind is None:
            continue
        for name, plugin in plugins.get(info.plugin_kind, {}).items():
            cls = getattr(plugin, "Options", None)
            if cls is None:
                continue
            where = f"params.{info.name}" + ("[]" if info.many else "")
            for opt in describe(cls):
                flag = flags.get((name, opt.name), f"--{name}-{opt.name.replace('_', '-')}")
                option = (f"`{flag}` / `--no-{flag[2:]}`" if opt.type is bool else f"`{flag}`")
                default = "none" if opt.default is None else _value(opt.default)
                rows.append([option, f"`{where}.{opt.name}`", f"{info.plugin_kind} `{name}`",
                             _TYPE_NAMES.get(opt.type, opt.type.__name__), default,
                             _range(opt), _escape(opt.help, table=True),
                             older_defaults(cls, opt.name)])
    return rows


def kind_section(kind: Any, plugins: dict[str, dict[str, Any]]) -> list[str]:
    """The reference of one job kind, from its declaration."""
    inputs = " ".join(i.name.upper() for i in kind.inputs)
    out = [f"### {kind.name}", "", _escape(kind.description), "",
           "```", f"inkmotion run {kind.name} {inputs} --out DIR [OPTIONS]",
           f"inkmotion submit {kind.name} {inputs} [OPTIONS]", "```", "",
           f"Queue: `{kind.queue}`.", ""]
    forms = {"source": "a file or `scheme:value`", "file": "a file", "text": "text"}
    out += _table(["input", "job.json", "form", "what"],
                  [[f"`{i.name.upper()}`", f"`inputs.{i.name}`", forms.get(i.form, i.form),
                    _escape(i.help, table=True)] for i in kind.inputs])
    out += _table(["option", "job.json", "type", "default", "allowed", "what",
                   "default in older specs"], _param_rows(kind.Params, "params.", plugins))
    options = _plugin_option_rows(kind, plugins)
    if options:
        out += ["Options of the plugins it can use (they apply when that plugin is chosen):", ""]
        out += _table(["option", "job.json", "plugin", "type", "default", "allowed", "what",
                       "default in older specs"], options)
    examples = list(getattr(kind, "examples", ()))
    if examples:
        out += ["Examples:", "", "```bash", *examples, "```", ""]
    return out


def _kind_extras(group: Any, ctx: Any, kind: Any) -> list[Any]:
    """The options every ``GROUP KIND`` command adds to the kind's own (e.g. ``--out``)."""
    from inkmotion.cli.kind_commands import SHELL_OPTIONS, plugin_options

    declared = {i.name for i in kind.inputs} | {"config"} | {i.name for i in SHELL_OPTIONS}
    declared |= {i.name for i in describe(kind.Params)} | set(plugin_options(kind))
    return [p for p in group.get_command(ctx, kind.name).params if p.name not in declared]


def kinds_section(root: Any, plugins: dict[str, dict[str, Any]]) -> list[str]:
    """``inkmotion run`` and ``inkmotion submit``, then every own job kind."""
    from inkmotion.cli.kind_commands import SHELL_OPTIONS

    ctx = _context(root)
    kinds = plugins["job-kind"]
    first = next(iter(kinds.values()))
    out = ["## Job kinds: inkmotion run, inkmotion submit", ""]
    for verb in KIND_GROUPS:
        group = root.get_command(ctx, verb)
        sub = _context(group, ctx)
        out += [f"### inkmotion {verb}", "", *help_markdown(group.help)]
        out += ["```", f"inkmotion {verb} KIND INPUT... [OPTIONS]"]
        if group.params:
            out.append(f"inkmotion {verb} {_usage(group.params)}")
        out += ["```", ""]
        rows = [_option_row(p) for p in group.params]
        shared = [["`--config`", "path", "", "A job.json to start from; the options given "
                   "override it."]]
        shared += [[f"`{i.option}`", _TYPE_NAMES[i.type], _value(i.default),
                    _escape(i.help, table=True)] for i in SHELL_OPTIONS]
        shared += [_option_row(p) for p in _kind_extras(group, sub, first)]
        if rows:
            out += [f"Options of `inkmotion {verb}` itself:", ""]
            out += _table(["option", "value", "default", "what"], rows)
        out += [f"Options of every `inkmotion {verb} KIND`, besides the kind's own:", ""]
        out += _table(["option", "value", "default", "what"], shared)
    out += ["The kinds (their options apply to `run` and `submit` alike; `job.json` names "
            "the key of the option in a job file, see [formats.md](formats.md#jobjson)):", ""]
    out += [f"- [{name}](#{name}): {_escape(k.description)}" for name, k in kinds.items()]
    out.append("")
    for kind in kinds.values():
        out += kind_section(kind, plugins)
    return out


# --- every other command ---------------------------------------------------------------------
def _context(command: Any, parent: Any = None) -> Any:
    return type(command).context_class(command, parent=parent, info_name=command.name)


def _is_argument(p: Any) -> bool:
    return getattr(p, "param_type_name", "") == "argument" or not getattr(p, "opts", [""])[0] \
        .startswith("-")


def _annotation(p: Any) -> Any:
    descriptor = getattr(p, "type_descriptor", None)
    return getattr(descriptor, "annotation", None)


def _value_name(p: Any) -> str:
    """What an option takes: INTEGER, PATH, ... (empty for a flag)."""
    if getattr(p, "is_flag", False):
        return ""
    if p.metavar:
        return p.metavar
    hint = _annotation(p)
    many = getattr(hint, "__origin__", None) is list
    if many:
        hint = hint.__args__[0]
    name = _TYPE_NAMES.get(hint)
    if name is None:
        name = getattr(getattr(p, "type", None), "name", "text")
    return name + (" (repeatable)" if getattr(p, "multiple", False) else "")


def _option_default(p: Any) -> str:
    if p.required:
        return "required"
    default = p.default
    if getattr(p, "is_flag", False):
        if p.secondary_opts:
            return f"`{p.opts[0] if default else p.secondary_opts[0]}`"
        return "on" if default else "off"
    if default is None or default == [] or default == ():
        return ""
    return _value(default)


def _option_row(p: Any) -> list[str]:
    names = ", ".join(f"`{o}`" for o in p.opts)
    if p.secondary_opts:
        names += " / " + ", ".join(f"`{o}`" for o in p.secondary_opts)
    return [names, _value_name(p), _option_default(p), _escape(getattr(p, "help", "") or "",
                                                               table=True)]


def _usage(params: list[Any]) -> str:
    words = []
    for p in params:
        if _is_argument(p):
            name = p.name.upper() + ("..." if p.nargs == -1 else "")
            words.append(name if p.required else f"[{name}]")
    return " ".join(words + ["[OPTIONS]"])


def command_section(command: Any, path: list[str], ctx: Any, level: int) -> list[str]:
    """One command (and, for a group, its subcommands) from the command tree."""
    title = " ".join(path)
    out = ["#" * level + " " + title, "", *help_markdown(command.help)]
    out += ["```", f"{title} {_usage(command.params)}"
            + (" COMMAND" if hasattr(command, "list_commands") else ""), "```", ""]
    arguments = [p for p in command.params if _is_argument(p)]
    options = [p for p in command.params if not _is_argument(p) and not p.hidden]
    out += _table(["argument", "value", "required", "what"],
                  [[f"`{p.name.upper()}`", _value_name(p), "yes" if p.required else "no",
                    _escape(getattr(p, "help", "") or "", table=True)] for p in arguments])
    out += _table(["option", "value", "default", "what"], [_option_row(p) for p in options])
    if hasattr(command, "list_commands"):
        sub = _context(command, ctx)
        for name in command.list_commands(sub):
            child = command.get_command(sub, name)
            if child is not None and not child.hidden:
                out += command_section(child, [*path, name], sub, min(level + 1, 4))
    return out


# --- the page --------------------------------------------------------------------------------
def _plugins_section(plugins: dict[str, dict[str, Any]]) -> list[str]:
    rows = []
    for kind, objects in plugins.items():
        for name, obj in objects.items():
            first = (obj.description or "").strip().splitlines()
            rows.append([kind, f"`{name}`", _escape(first[0] if first else "", table=True)])
    return ["## Built-in plugins", "",
            "What `inkmotion plugins` lists for the project itself (a third-party package adds "
            "its own rows there; see [plugins.md](plugins.md)):", "",
            *_table(["kind", "name", "what"], rows)]


def _short(command: Any) -> str:
    text = command.short_help or inspect.cleandoc(command.help or "").split("\n\n")[0]
    return _escape(" ".join(text.split()), table=True)


def reference() -> str:
    """docs/cli.md (module docstring)."""
    import typer

    from inkmotion.cli.main import app

    root = typer.main.get_command(app)
    ctx = _context(root)
    plugins = own_plugins()
    names = [n for n in root.list_commands(ctx) if not root.get_command(ctx, n).hidden]
    out = ["# Command-line reference", "",
           "<!-- Generated by `python -m inkmotion.cli.reference > docs/cli.md` (`make docs`) "
           "from the kinds' declarations and the command tree; do not edit by hand: "
           "tests/test_docs.py fails when it differs. -->", "",
           "Every command of `inkmotion`, with its arguments, options and defaults, and every "
           "built-in job kind with its parameters, the options of the plugins it can use and "
           "their job.json keys. `inkmotion COMMAND --help` says the same on the terminal; a "
           "plugin package installed beside inkmotion adds its own kinds and options there.",
           "", "## inkmotion", "", *help_markdown(root.help),
           "```", "inkmotion [OPTIONS] COMMAND [ARGS]...", "```", ""]
    rows = []
    for name in names:
        anchor = ("job-kinds-inkmotion-run-inkmotion-submit" if name in KIND_GROUPS
                  else f"inkmotion-{name}")
        rows.append([f"[`{name}`](#{anchor})", _short(root.get_command(ctx, name))])
    out += _table(["command", "what"], rows)
    out += ["Contents: [job kinds](#job-kinds-inkmotion-run-inkmotion-submit) · "
            "[other commands](#other-commands) · [built-in plugins](#built-in-plugins)", ""]
    out += kinds_section(root, plugins)
    out += ["## Other commands", ""]
    for name in names:
        if name not in KIND_GROUPS:
            out += command_section(root.get_command(ctx, name), ["inkmotion", name], ctx, 3)
    out += _plugins_section(plugins)
    while out and out[-1] == "":
        out.pop()
    return "\n".join(out) + "\n"


def main() -> None:
    """Print the reference (``python -m inkmotion.cli.reference > docs/cli.md``)."""
    sys.stdout.write(reference())


if __name__ == "__main__":
    main()
