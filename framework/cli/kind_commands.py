"""``inkmotion run KIND`` and ``inkmotion submit KIND``, generated from the job kinds.

Luigi-style: each job kind declares its inputs and parameters (:mod:`inkmotion.jobs.kind`,
:mod:`inkmotion.jobs.params`), and each plugin its options; the commands are built from
those declarations, so a new kind — built-in or from another package — gets ``run`` and
``submit`` commands with ``--help`` and examples without a line of CLI code. A plugin's
options appear as ``--PLUGIN-OPTION`` (e.g. ``--dce-threshold``) and apply when that
plugin is chosen.

The groups list and build their commands lazily: only the kind asked for is looked at, and
nothing here imports torch, so ``--help`` answers at once.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, Optional

import typer
import typer.core

from inkmotion.errors import SpecError
from inkmotion.jobs.params import ParamInfo, check_scalar, describe
from inkmotion.jobs.spec import JobSpec

#: shell-level options every kind shares (spec fields, not the kind's params)
SHELL_OPTIONS = (
    ParamInfo("seed", int, 0, "Random seed.", minimum=0),
    ParamInfo("device", str, "auto", "cpu, cuda, cuda:N or auto (CUDA when present)."),
    ParamInfo("record_every", int, 10,
              "Rendered images into recording.rrd every k steps (0: none).", minimum=0),
)


def _default_text(info: ParamInfo) -> str:
    default = info.default
    if info.plugin_kind is not None:
        if isinstance(default, list):
            return ", ".join(c.name for c in default) or "none"
        return default.name if default is not None else "auto"
    return "" if default is None else f"{default:g}" if isinstance(default, float) else str(
        default)


def _escape(text: str) -> str:
    return text.replace("[", "\\[")  # rich markup


def option_parameter(info: ParamInfo, dest: str) -> inspect.Parameter:
    """A typer option for one parameter, as a signature entry; unset options are None (the
    config's or the kind's default applies)."""
    help_text = _escape(f"{info.help} [default: {_default_text(info)}]")
    py: Any = {int: int, float: float, bool: bool}.get(info.type, str)
    if info.plugin_kind is not None:
        py = str
    if info.many:
        py = list[str]
    if py is bool:
        name = info.option[2:]
        opt = typer.Option(f"--{name}/--no-{name}", help=help_text, show_default=False)
    else:
        opt = typer.Option(info.option, help=help_text, show_default=False,
                           metavar="NAME" if info.plugin_kind else None)
    return inspect.Parameter(dest, inspect.Parameter.KEYWORD_ONLY, default=None,
                             annotation=Annotated[Optional[py], opt])  # noqa: UP045


def plugin_options(kind: Any) -> dict[str, tuple[ParamInfo, str, ParamInfo]]:
    """``dest -> (the kind's plugin parameter, plugin name, option)`` for every option of
    every registered plugin the kind's parameters can choose."""
    from inkmotion.plugin_host import host

    out: dict[str, tuple[ParamInfo, str, ParamInfo]] = {}
    for info in describe(kind.Params):
        if info.plugin_kind is None:
            continue
        for name, plugin in sorted(host().plugins(info.plugin_kind).items()):
            cls = getattr(plugin, "Options", None)
            for opt in describe(cls) if cls is not None else []:
                flag = f"--{name}-{opt.name.replace('_', '-')}"
                dest = flag[2:].replace("-", "_")
                if dest not in out:
                    out[dest] = (info, name, ParamInfo(
                        opt.name, opt.type, opt.default,
                        f"{opt.help} (with {info.name} {name})", opt.optional, opt.minimum,
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
        spec.inputs[info.name] = value
    for info in SHELL_OPTIONS:
        if values.get(info.name) is not None:
            setattr(spec, info.name, check_scalar(info, values[info.name], "options"))
    params = describe(kind.Params)
    for info in params:
        value = values.get(info.name)
        if value is None or (info.many and not value):
            continue
        if info.plugin_kind is None:
            spec.params[info.name] = value
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
    lines = [kind.description, "", "Examples:", ""]
    for example in getattr(kind, "examples", ()):
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


def kind_command(kind: Any, verb: str, callback: Callable[[str, list[str], dict], None],
                 extra: list[inspect.Parameter]) -> Any:
    """The ``run KIND`` / ``submit KIND`` command of ``kind``: its inputs as arguments, its
    parameters, its plugins' options and the shell options, plus ``extra``."""
    inputs = [i.name for i in kind.inputs]
    params = [inspect.Parameter(i.name, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=None,
                                annotation=Annotated[Optional[str], typer.Argument(  # noqa: UP045
                                    help=_escape(i.help), show_default=False)])
              for i in kind.inputs]
    params.append(inspect.Parameter(
        "config", inspect.Parameter.KEYWORD_ONLY, default=None,
        annotation=Annotated[Optional[Path], typer.Option(  # noqa: UP045
            "--config", help="A job.json to start from; options override it.")]))
    params += [option_parameter(info, info.name) for info in SHELL_OPTIONS]
    params += [option_parameter(info, info.name) for info in describe(kind.Params)]
    params += [option_parameter(opt, dest) for dest, (_, _, opt) in plugin_options(kind).items()]
    params += extra

    def command(**values: Any) -> None:
        given = [values.pop(n) for n in inputs]
        callback(kind.name, [g for g in given if g is not None], values)

    command.__signature__ = inspect.Signature(params)  # type: ignore[attr-defined]
    command.__annotations__ = {p.name: p.annotation for p in params}
    single = typer.Typer(add_completion=False, rich_markup_mode="rich")
    single.command(kind.name, help=_help(kind, verb), short_help=kind.description)(command)
    return typer.main.get_command(single)


class KindGroup(typer.core.TyperGroup):
    """A group whose subcommands are the registered job kinds, built on demand (a subclass
    sets :meth:`make`)."""

    def make(self, kind: Any) -> Any:
        raise NotImplementedError

    def list_commands(self, ctx: Any) -> list[str]:
        from inkmotion.plugin_host import host

        return sorted(host().plugins("job-kind"))

    def get_command(self, ctx: Any, name: str) -> Any:
        from inkmotion.cli.errors import fail
        from inkmotion.plugin_host import host

        kinds = host().plugins("job-kind")
        if name not in kinds:
            fail(f"Unknown job kind {name!r}; kinds are: {', '.join(sorted(kinds)) or 'none'} "
                 "(`inkmotion plugins` lists them).")
        return self.make(kinds[name])
