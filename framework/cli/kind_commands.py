"""``inkmotion run KIND`` and ``inkmotion submit KIND``, generated from the job kinds.

Luigi-style: each job kind declares its inputs and parameters (:mod:`inkmotion.jobs.kind`,
:mod:`inkmotion.jobs.params`), and each plugin its options; the commands are built from
those declarations, so a new kind — built-in or from another package — gets ``run`` and
``submit`` commands with ``--help`` and examples without a line of CLI code. A plugin's
options appear as ``--PLUGIN-OPTION`` (e.g. ``--dce-threshold``) and apply when that
plugin is chosen.

The groups list and build their commands lazily: only the kind asked for is looked at, and
nothing here imports torch, so ``--help`` answers at once.

``--help`` groups the options in panels, so that they read at 80 columns: the command's own
(:data:`IO_PANEL`: ``--out``, ``--config``, ...) first, then the kind's parameters, the
settings every job has, and one panel per plugin with that plugin's options. Each panel is
its own table, sized to its own longest option name, so names are never cut.
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, Optional

import typer
import typer.core

from inkmotion.errors import SpecError
from inkmotion.jobs.params import ParamInfo, check_scalar, describe
from inkmotion.jobs.spec import MAX_SEED, JobSpec

#: the panel of the command's own options (``--out``, ``--config``, ``--force``, ...)
IO_PANEL = "Input/Output"
#: the panel of the shell-level options every kind shares
SHELL_PANEL = "Every job"

#: shell-level options every kind shares (spec fields, not the kind's params)
SHELL_OPTIONS = (
    ParamInfo("seed", int, 0, "Random seed.", minimum=0, maximum=MAX_SEED),
    ParamInfo("device", str, "auto", "cpu, cuda, cuda:N or auto (CUDA when present)."),
    ParamInfo("threads", int, None, "CPU threads of the job, fixed for its whole run and "
              "recorded in job.json (default: INKMOTION_THREADS, or OMP_NUM_THREADS, else 1: "
              "a fit gains nothing from a second thread).", optional=True, minimum=1),
    ParamInfo("record_every", int, 10,
              "Rendered images into recording.rrd every k steps (0: none).", minimum=0),
)


def _default_text(info: ParamInfo) -> str:
    default = info.default
    if info.plugin_kind is not None:
        if isinstance(default, list):
            return ", ".join(c.name for c in default) or "none"
        return default.name if default is not None else "auto"
    if isinstance(default, bool):
        return "on" if default else "off"
    return "" if default is None else f"{default:g}" if isinstance(default, float) else str(
        default)


def _escape(text: str) -> str:
    return text.replace("[", "\\[")  # rich markup


def option_parameter(info: ParamInfo, dest: str, panel: str | None = None) -> inspect.Parameter:
    """A typer option for one parameter, as a signature entry, shown in help panel
    ``panel``; unset options are None (the config's or the kind's default applies)."""
    default = _default_text(info)
    text = info.help
    if info.choices and not all(c in text for c in info.choices):  # choices not told
        text = f"{text} One of: {', '.join(info.choices)}."
    help_text = _escape(f"{text} [default: {default}]" if default else text)
    py: Any = {int: int, float: float, bool: bool}.get(info.type, str)
    if info.plugin_kind is not None:
        py = str
    if info.many:
        py = list[str]
    if py is bool:
        name = info.option[2:]
        opt = typer.Option(f"--{name}/--no-{name}", help=help_text, show_default=False,
                           rich_help_panel=panel)
    else:
        opt = typer.Option(info.option, help=help_text, show_default=False,
                           metavar="NAME" if info.plugin_kind else None,
                           rich_help_panel=panel)
    return inspect.Parameter(dest, inspect.Parameter.KEYWORD_ONLY, default=None,
                             annotation=Annotated[Optional[py], opt])  # noqa: UP045


def plugin_options(kind: Any) -> dict[str, tuple[ParamInfo, str, ParamInfo]]:
    """``dest -> (the kind's plugin parameter, plugin name, option)`` for every option of
    every registered plugin the kind's parameters can choose."""
    from inkmotion.plugin_host import host
    from inkmotion.plugin_host.protocols import option_flag

    out: dict[str, tuple[ParamInfo, str, ParamInfo]] = {}
    for info in describe(kind.Params):
        if info.plugin_kind is None:
            continue
        for name, plugin in sorted(host().plugins(info.plugin_kind).items()):
            cls = getattr(plugin, "Options", None)
            for opt in describe(cls) if cls is not None else []:
                flag = option_flag(name, opt.name)
                dest = flag[2:].replace("-", "_")
                if dest not in out:
                    out[dest] = (info, name, ParamInfo(
                        opt.name, opt.type, opt.default,
                        opt.help, opt.optional, opt.minimum,
                        opt.maximum, opt.choices, flag=flag))
    return out


def spec_from_options(kind_name: str, inputs: list[str] | tuple[str, ...],
                      values: dict[str, Any], config: Path | None = None) -> JobSpec:
    """The spec the command-line options describe: ``config`` (a job.json) or the kind's
    defaults, overridden by every option that was given (not None)."""
    from inkmotion.jobs.kind import job_kind

    kind = job_kind(kind_name)
    if config is not None:
        spec = JobSpec.load(config)
        if spec.kind != kind_name:
            raise SpecError(f"{config} is a {spec.kind} job, not {kind_name}; run it with "
                            f"`inkmotion run {spec.kind} --config {config}`.")
    else:
        spec = JobSpec(kind=kind_name)
    declared = list(kind.inputs)
    if len(inputs) > len(declared):
        raise SpecError(f"The {kind_name} job takes {len(declared)} input(s) "
                        f"({', '.join(i.name for i in declared)}), got {len(inputs)}.")
    for info, value in zip(declared, inputs, strict=False):
        spec.inputs[info.name] = _absolute(value) if info.form != "text" else value
    for info in SHELL_OPTIONS:
        if values.get(info.name) is not None:
            setattr(spec, info.name, check_scalar(info, values[info.name], "options"))
    params = describe(kind.Params)
    for info in params:
        value = values.get(info.name)
        if value is None or (info.many and not value):
            continue
        if info.plugin_kind is None:
            spec.params[info.name] = _absolute(value) if info.file else value
        elif info.many:
            spec.params[info.name] = [{"name": v} for v in value]
        else:
            current = spec.params.get(info.name)
            same = isinstance(current, dict) and current.get("name") == value
            spec.params[info.name] = current if same else {"name": value}
    for dest, (info, plugin_name, opt) in plugin_options(kind).items():
        value = values.get(dest)
        if value is None:
            continue
        _set_plugin_option(spec, info, plugin_name, opt, value)
    return spec


def _absolute(value: Any) -> Any:
    """A relative path to an existing file given on the command line, made absolute: the
    job.json then runs again from any folder (``run --config``, the gallery's command);
    anything else (``sample:NAME``, ``text:WORD``, a name, a missing file, said later) as
    given."""
    if isinstance(value, str) and value and not Path(value).is_absolute() \
            and Path(value).is_file():
        return os.path.abspath(value)
    return value


def _set_plugin_option(spec: JobSpec, info: ParamInfo, plugin_name: str, opt: ParamInfo,
                       value: Any) -> None:
    """Put ``--PLUGIN-OPTION value`` under the parameter that chose that plugin."""
    current = spec.params.get(info.name)
    if current is None:
        current = [c.to_dict() for c in info.default] if info.many else (
            info.default.to_dict() if info.default is not None else None)
    choices = current if isinstance(current, list) else [current]
    choices = [{"name": c} if isinstance(c, str) else c for c in choices if c is not None]
    target = [c for c in choices if isinstance(c, dict) and c.get("name") == plugin_name]
    if not target:
        chosen = ", ".join(str(c.get("name")) for c in choices if isinstance(c, dict))
        raise SpecError(f"{opt.option} applies to the {plugin_name} {info.plugin_kind}, but this "
                        f"job uses {chosen or 'none'}; add {info.option} {plugin_name} or drop "
                        f"{opt.option}.")
    target[0][opt.name] = value
    spec.params[info.name] = choices if info.many else choices[0]


def _help(kind: Any, verb: str) -> str:
    examples = tuple(getattr(kind, "examples", ()))
    lines = [kind.description, "", "Examples:", ""] if examples else [kind.description]
    for example in examples:
        if verb == "submit":
            example = example.replace("inkmotion run", "inkmotion submit")
            example = " ".join(_drop_out(example.split()))
        lines += [f"  {example}", ""]
    return _escape("\n\n".join(line for line in lines if line))


def _drop_out(words: list[str]) -> list[str]:
    """An example's words without ``--out DIR`` (submit chooses the folder)."""
    out, skip = [], False
    for w in words:
        if skip:
            skip = False
            continue
        if w == "--out":
            skip = True
            continue
        out.append(w)
    return out


def plugin_panel(info: ParamInfo, plugin_name: str) -> str:
    """The help panel of one plugin's options, e.g. ``dce initialiser (--initialiser dce)``."""
    return f"{plugin_name} {info.plugin_kind} ({info.option} {plugin_name})"


class KindCommand(typer.core.TyperCommand):
    """A ``run KIND`` / ``submit KIND`` command; its ``--help`` option sits in
    :data:`IO_PANEL` with the command's own options (not in a panel of its own first), and
    a switch shows as one name, ``--[no-]merge``, rather than in a column of ``--no-...``
    names that would take a third of an 80-column help."""

    def get_help_option(self, ctx: Any) -> Any:
        option = super().get_help_option(ctx)
        if option is not None:
            option.rich_help_panel = IO_PANEL
        return option

    def format_help(self, ctx: Any, formatter: Any) -> None:
        switches = [p for p in self.params if len(p.opts) == 1 and len(p.secondary_opts) == 1
                    and p.secondary_opts[0] == "--no-" + p.opts[0][2:]]
        saved = [(p.opts, p.secondary_opts, p.help, p.show_default) for p in switches]
        try:
            for p in switches:
                p.opts, p.secondary_opts = ["--[no-]" + p.opts[0][2:]], []
                if p.show_default:  # typer would now print the default as True / False
                    p.help = f"{p.help} \\[default: {'on' if p.default else 'off'}]"
                    p.show_default = False
            super().format_help(ctx, formatter)
        finally:
            for p, (opts, secondary, text, show) in zip(switches, saved, strict=True):
                p.opts, p.secondary_opts, p.help, p.show_default = opts, secondary, text, show


def kind_command(kind: Any, verb: str, callback: Callable[[str, list[str], dict], None],
                 extra: list[inspect.Parameter]) -> Any:
    """The ``run KIND`` / ``submit KIND`` command of ``kind``: its inputs as arguments,
    ``extra`` (the command's own options, in :data:`IO_PANEL`) and ``--config``, the kind's
    parameters, the shell options, and its plugins' options, a help panel each."""
    inputs = [i.name for i in kind.inputs]
    params = [inspect.Parameter(i.name, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=None,
                                annotation=Annotated[Optional[str], typer.Argument(  # noqa: UP045
                                    help=_escape(i.help), show_default=False)])
              for i in kind.inputs]
    params += extra
    params.append(inspect.Parameter(
        "config", inspect.Parameter.KEYWORD_ONLY, default=None,
        annotation=Annotated[Optional[Path], typer.Option(  # noqa: UP045
            "--config", help="A job.json to start from; options override it.",
            rich_help_panel=IO_PANEL)]))
    own = f"{kind.name} parameters"
    params += [option_parameter(info, info.name, own) for info in describe(kind.Params)]
    params += [option_parameter(info, info.name, SHELL_PANEL) for info in SHELL_OPTIONS]
    params += [option_parameter(opt, dest, plugin_panel(info, name))
               for dest, (info, name, opt) in plugin_options(kind).items()]

    def command(**values: Any) -> None:
        given = [values.pop(n) for n in inputs]
        callback(kind.name, [g for g in given if g is not None], values)

    command.__signature__ = inspect.Signature(params)  # type: ignore[attr-defined]
    command.__annotations__ = {p.name: p.annotation for p in params}
    single = typer.Typer(add_completion=False, rich_markup_mode="rich")
    single.command(kind.name, cls=KindCommand, help=_help(kind, verb),
                   short_help=kind.description)(command)
    return typer.main.get_command(single)


def config_of(args: list[str]) -> str | None:
    """The value of ``--config`` on a command line (``--config X`` or ``--config=X``)."""
    for i, arg in enumerate(args):
        if arg == "--config" and i + 1 < len(args):
            return args[i + 1]
        if arg.startswith("--config="):
            return arg.split("=", 1)[1]
    return None


class KindGroup(typer.core.TyperGroup):
    """A group whose subcommands are the registered job kinds, built on demand (a subclass
    sets :meth:`make`).

    ``GROUP --config job.json [options]`` (no kind first) is ``GROUP KIND --config job.json
    [options]`` with job.json's kind: the kind's own command parses the whole command line,
    so the overrides are those of ``GROUP KIND --config`` and an option the kind does not
    have is one sentence."""

    def make(self, kind: Any) -> Any:
        raise NotImplementedError

    def list_commands(self, ctx: Any) -> list[str]:
        from inkmotion.plugin_host import host

        return sorted(host().plugins("job-kind"))

    def get_command(self, ctx: Any, name: str) -> Any:
        from inkmotion.cli.errors import fail
        from inkmotion.errors import InkmotionError
        from inkmotion.jobs.kind import job_kind

        try:
            kind = job_kind(name)
        except InkmotionError as exc:  # unknown, or a plugin that failed to load: why
            fail(exc)
        return self.make(kind)

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        config = config_of(args)
        if args and args[0].startswith("-") and config is not None:
            args = [self._kind_of(ctx, Path(config), args), *args]
        return super().parse_args(ctx, args)

    def _kind_of(self, ctx: Any, config: Path, args: list[str]) -> str:
        """The kind of job file ``config``, once every option in ``args`` is known to it."""
        from inkmotion.cli.errors import EXIT_USAGE, fail
        from inkmotion.errors import InkmotionError

        try:
            kind = JobSpec.load(config).kind
        except InkmotionError as exc:
            fail(exc)
        command = self.get_command(ctx, kind)
        known = set(ctx.help_option_names)
        for param in command.params:
            known |= {*param.opts, *param.secondary_opts}
        options = args[:args.index("--")] if "--" in args else args  # "--" ends options
        unknown = [a.split("=", 1)[0] for a in options
                   if a.startswith("--") and a.split("=", 1)[0] not in known]
        if unknown:
            fail(f"{unknown[0]} is not an option of {kind} jobs ({config} is a {kind} job); "
                 f"`inkmotion {ctx.info_name} {kind} --help` lists the options.",
                 code=EXIT_USAGE)
        return kind
