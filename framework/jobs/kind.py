"""Job kinds: what a job-kind plugin declares, and a spec checked against its kind.

A job kind (fit, tag, abstract, simulate, evaluate, or a third party's) is a plugin object
registered through the ``inkmotion_job_kinds`` hook, with

- ``name``, ``description`` (first line shown by ``inkmotion plugins``), ``examples``
  (command lines shown by ``--help``);
- ``queue``: the Celery queue its jobs go to (the one source of truth for kind -> queue);
- ``inputs``: a tuple of :class:`InputSpec`, the named inputs of a job;
- ``Params``: a dataclass of its parameters (:mod:`inkmotion.jobs.params`);
- ``steps(params) -> int``: how many steps it will report;
- ``run(job) -> dict``: do the work inside the shell (:mod:`inkmotion.jobs.shell`) and
  return the report; the shell writes job.json and report.json and commits the folder.

Nothing here imports torch: ``inkmotion run --help`` lists the kinds at once.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from inkmotion.errors import SpecError
from inkmotion.geometry.input_file import missing_file
from inkmotion.inputs.sources import is_scheme
from inkmotion.jobs.params import (
    PluginChoice,
    describe,
    options_dict,
    parse,
    plugin_options,
)
from inkmotion.jobs.spec import SPEC_VERSION, JobSpec
from inkmotion.samples import locate


@dataclass(frozen=True)
class InputSpec:
    """One named input of a job kind.

    ``form``: "source" — a file path or ``scheme:value`` read by a reader plugin (e.g.
    ``text:hello``); "file" — a file path; "text" — a plain string (e.g. a caption).
    """

    name: str
    help: str
    form: str = "source"


@dataclass
class ResolvedJob:
    """A spec checked against its kind: the kind plugin, parsed params, plugin options."""

    spec: JobSpec
    kind: Any  # the job-kind plugin object
    params: Any  # an instance of kind.Params
    options: dict[int, Any]  # id(PluginChoice) -> that plugin's parsed options

    def plugin(self, choice: PluginChoice) -> Any:
        from inkmotion.plugin_host import host

        return host().get(choice.kind, choice.name)

    def options_of(self, choice: PluginChoice) -> Any:
        return self.options.get(id(choice))

    def full_spec(self) -> JobSpec:
        """The spec with every parameter and plugin option written out (defaults
        included, an older spec version's where it left them out), as the current
        version: job.json reproduces the run even if a default changes later."""
        params = {}
        for info in describe(self.kind.Params):
            value = getattr(self.params, info.name)
            if info.plugin_kind is None:
                params[info.name] = value
                continue
            choices = [self._full(c) for c in (value if isinstance(value, list) else [value])]
            params[info.name] = choices if info.many else choices[0]
        spec = self.spec.copy()
        spec.params = params
        spec.version = SPEC_VERSION
        return spec

    def _full(self, choice: PluginChoice | None) -> dict[str, Any] | None:
        if choice is None:
            return None
        return {"name": choice.name, **options_dict(self.options_of(choice))}


def job_kind(name: str) -> Any:
    """The job-kind plugin ``name`` (a clear error lists the kinds)."""
    from inkmotion.plugin_host import host

    kinds = host().plugins("job-kind")
    if name not in kinds:
        if host().broken or host().disabled:  # it may be among them: say which and why
            return host().get("job-kind", name)
        raise SpecError(f"Unknown job kind {name!r}; kinds are: {', '.join(sorted(kinds))} "
                        "(`inkmotion plugins` lists them with their packages).")
    return kinds[name]


def warm_up_job_kinds(kinds: dict[str, Any] | None = None,
                      queues: Collection[str] | None = None) -> tuple[list[str], list[str]]:
    """Call the optional ``warm_up`` (what its ``run`` imports) of each job kind, ``kinds``
    by name (default: every registered kind), whose queue is among ``queues`` (default:
    any; a worker names those it consumes, so one for plots does not import torch): the
    kinds warmed up, and one sentence per kind whose warm-up raised (its first job then
    pays its imports, and shows the error again if it is real)."""
    from inkmotion.plugin_host import host

    warmed, failed = [], []
    kinds = host().plugins("job-kind") if kinds is None else kinds
    for name, kind in sorted(kinds.items()):
        warm_up = getattr(kind, "warm_up", None)
        if warm_up is None or (queues is not None and kind.queue not in queues):
            continue
        try:
            warm_up()
        except Exception as exc:  # a broken plugin must not stop a worker from starting
            failed.append(f"warming up the job kind {name!r} failed ({exc}); its first job "
                          "imports what it needs")
        else:
            warmed.append(name)
    return warmed, failed


def resolve(spec: JobSpec, source: str = "job spec", check_inputs: bool = True) -> ResolvedJob:
    """Check ``spec`` against its kind: inputs present (and files existing), parameters
    known and in range, plugins registered, their options valid. Raises SpecError or
    PluginError with one sentence."""
    kind = job_kind(spec.kind)
    _check_inputs(kind, spec, source, check_inputs)
    params = parse(kind.Params, spec.params, source, version=spec.version)
    check = getattr(params, "validate", None)
    if check is not None:
        check()
    options: dict[int, Any] = {}
    for info in describe(kind.Params):
        if info.plugin_kind is None:
            continue
        value = getattr(params, info.name)
        for choice in (value if isinstance(value, list) else [value]):
            if choice is None:
                continue
            from inkmotion.plugin_host import host

            plugin = host().get(info.plugin_kind, choice.name)
            options[id(choice)] = plugin_options(plugin, choice, source, spec.version)
    return ResolvedJob(spec, kind, params, options)


def _check_inputs(kind: Any, spec: JobSpec, source: str, check_files: bool) -> None:
    declared = {i.name: i for i in kind.inputs}
    unknown = sorted(set(spec.inputs) - set(declared))
    if unknown:
        raise SpecError(f"{source}: the {spec.kind} job has no input(s) {', '.join(unknown)}; "
                        f"its inputs are {', '.join(declared) or 'none'}.")
    for name, info in declared.items():
        value = spec.inputs.get(name, "")
        if not str(value).strip():
            help_text = info.help.rstrip(".")
            example = next(iter(getattr(kind, "examples", ()) or ()), None)
            raise SpecError(f"The {spec.kind} job needs its {name} input ("
                            f"{help_text[:1].lower()}{help_text[1:]})"
                            + (f", e.g. {example.split('  #')[0].strip()}." if example
                               else "."))
        if not check_files or info.form == "text":
            continue
        value = locate(value)  # sample:NAME -> its shipped file; an unknown name is refused
        if info.form == "source" and is_scheme(value):
            continue
        if info.form == "file" and is_scheme(value) and not Path(value).exists():
            raise SpecError(f"{value}: the {spec.kind} job's {name} input is a file ("
                            f"{info.help.rstrip('.')}), not a {value.split(':')[0]}: source; "
                            f"for a drawing, fit it first (inkmotion run fit {value} --out "
                            "DIR) and give DIR/plan.json.")
        problem = missing_file(value, name)
        if problem is not None:
            raise SpecError(problem)
