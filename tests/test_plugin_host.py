"""The plugin host: built-ins through entry points, validation against the protocols,
broken plugins."""

from __future__ import annotations

import sys
import textwrap
from dataclasses import dataclass
from typing import Protocol

import pytest

import inkmotion
from inkmotion.errors import PluginError
from inkmotion.plugin_host import KIND_HOOKS, PluginHost, hookimpl, host, protocols
from inkmotion.plugin_host.protocols import (
    OPTIONAL,
    PROTOCOLS,
    check_plugin_object,
    protocol_members,
)

BUILT_INS = {("reader", "gml"), ("reader", "svg"), ("reader", "text"),
             ("initialiser", "dce"), ("image-loss", "mse"), ("renderer", "raster")}


def test_built_ins_are_registered_through_entry_points() -> None:
    rows = {(r.kind, r.name): r for r in host().table()}
    assert BUILT_INS <= set(rows)
    for key in BUILT_INS:
        assert rows[key].origin.startswith("inkmotion (inkmotion.plugins.")
        assert rows[key].description and "\n" not in rows[key].description
    assert not host().broken, host().broken


def test_plugin_lookup_and_unknown_name() -> None:
    renderer = inkmotion.plugin("renderer", "raster")
    assert renderer.name == "raster" and callable(renderer)
    with pytest.raises(PluginError, match="Unknown renderer plugin 'nope'; available: raster"):
        inkmotion.plugin("renderer", "nope")
    with pytest.raises(PluginError, match="Unknown plugin kind"):
        inkmotion.plugin("brush", "raster")


def _dist(tmp_path, group: str, entries: dict[str, str]) -> None:
    """A real installed distribution (dist-info on sys.path) declaring ``entries``."""
    info = tmp_path / "thirdparty_plugins-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: thirdparty-plugins\n"
                                   "Version: 0.1\n")
    lines = "\n".join(f"{k} = {v}" for k, v in entries.items())
    (info / "entry_points.txt").write_text(f"[{group}]\n{lines}\n")


def _renderer_module(path, name: str, description: str, image: str) -> None:
    """A third-party plugin module with one renderer ``name`` returning ``image``."""
    path.write_text(textwrap.dedent(f'''
        from inkmotion.plugin_host import hookimpl

        class Renderer:
            name = {name!r}
            description = {description!r}
            def __call__(self, segments, widths, height, width):
                import torch
                return {image}

        @hookimpl
        def inkmotion_renderers():
            return [Renderer()]
    '''))


def test_third_party_and_broken_plugins(tmp_path, monkeypatch) -> None:
    _renderer_module(tmp_path / "tp_good.py", "blank", "Renders nothing (a third-party "
                     "example).", "torch.zeros(height, width)")
    (tmp_path / "tp_broken.py").write_text("import not_a_real_module_xyz\n")
    _dist(tmp_path, "inkmotion_test", {"good": "tp_good", "broken": "tp_broken"})
    monkeypatch.syspath_prepend(str(tmp_path))
    h = PluginHost()
    with pytest.warns(UserWarning, match="broken"):
        h.load_entry_points("inkmotion_test")
    assert h.get("renderer", "blank")(None, None, 2, 3).shape == (2, 3)
    assert [b.name for b in h.broken] == ["broken"]
    assert "not_a_real_module_xyz" in h.broken[0].error
    with pytest.raises(PluginError, match="failed to load"):
        h.get("renderer", "broken")
    # asked for by the name its object would have had (not its entry point's), the error
    # still points at the package that failed
    with pytest.raises(PluginError, match=r"Unknown renderer plugin 'blnk'; available: .*"
                       r"1 plugin package\(s\) failed to load and may hold it: 'broken' from "
                       r".*`inkmotion plugins` says why"):
        h.get("renderer", "blnk")
    for name in ("tp_good", "tp_broken"):
        sys.modules.pop(name, None)


def test_hook_signature_is_verified() -> None:
    class Wrong:
        @hookimpl
        def inkmotion_renderers(self, unexpected_argument):  # not in the spec
            return []

    with pytest.raises(PluginError, match="invalid hook") as info:
        PluginHost().register(Wrong(), name="wrong")
    assert "\n" not in str(info.value) and "unexpected_argument" in str(info.value)


def test_unknown_hook_fails_early(tmp_path, monkeypatch) -> None:
    (tmp_path / "tp_typo.py").write_text(textwrap.dedent('''
        from inkmotion.plugin_host import hookimpl

        @hookimpl
        def inkmotion_renderes():
            return []
    '''))
    _dist(tmp_path, "inkmotion_typo", {"typo": "tp_typo"})
    monkeypatch.syspath_prepend(str(tmp_path))
    h = PluginHost()
    with pytest.warns(UserWarning, match="typo"):
        h.load_entry_points("inkmotion_typo")
    assert [b.name for b in h.broken] == ["typo"]
    assert "inkmotion_renderes" in h.broken[0].error
    sys.modules.pop("tp_typo", None)


def test_loading_every_plugin_imports_no_torch() -> None:
    """Registering the built-ins (and any installed third-party plugin) imports no torch:
    the command line lists kinds and options at once; implementations load on first use."""
    import subprocess

    code = ("import sys; from inkmotion.plugin_host import host; h = host(); "
            "assert h.plugins('renderer') and h.plugins('job-kind'); "
            "print(sorted(n for n in sys.modules if n == 'torch' or n.startswith("
            "('inkmotion.rendering', 'inkmotion.image_losses', 'inkmotion.sigma_lognormal'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_a_blocked_built_in_is_not_loaded_and_a_third_party_plugin_takes_its_name(
        tmp_path, monkeypatch) -> None:
    """INKMOTION_DISABLE_PLUGINS=raster (pluggy's set_blocked by entry-point name): the
    built-in renderer module is never imported, ``inkmotion plugins`` lists it as disabled,
    asking for it says why, and another package's renderer named "raster" registers, where
    without the block the two names would clash."""
    _renderer_module(tmp_path / "tp_raster.py", "raster", "A third-party renderer that "
                     "replaces the built-in.", "torch.ones(height, width)")
    monkeypatch.syspath_prepend(str(tmp_path))
    import tp_raster

    clash = PluginHost()
    clash.load_entry_points()
    with pytest.raises(PluginError, match="Two renderer plugins are named 'raster'"):
        clash.register(tp_raster, name="tp_raster", origin="thirdparty")

    monkeypatch.setenv("INKMOTION_DISABLE_PLUGINS", "raster, nosuchplugin")
    h = PluginHost()
    with pytest.warns(UserWarning, match="'nosuchplugin', which no installed plugin has"):
        h.load_entry_points()
    assert "raster" not in h.plugins("renderer")
    assert [(d.name, d.error) for d in h.disabled] == [
        ("raster", "disabled by INKMOTION_DISABLE_PLUGINS")]
    with pytest.raises(PluginError, match="switched off by INKMOTION_DISABLE_PLUGINS"):
        h.get("renderer", "raster")
    h.register(tp_raster, name="tp_raster", origin="thirdparty")
    assert h.get("renderer", "raster")(None, None, 2, 2).sum() == 4
    sys.modules.pop("tp_raster", None)


def test_plugins_lists_a_disabled_plugin() -> None:
    import json
    import os
    import subprocess

    env = {**os.environ, "INKMOTION_DISABLE_PLUGINS": "spray"}
    res = subprocess.run([sys.executable, "-m", "inkmotion", "plugins", "--json"], env=env,
                         capture_output=True, text=True, check=True)
    rows = json.loads(res.stdout)
    assert {"kind": "?", "name": "spray", "origin": "inkmotion (inkmotion.plugins.spray)",
            "description": "disabled", "error": "disabled by INKMOTION_DISABLE_PLUGINS"} in rows
    assert not any(r["kind"] == "renderer" and r["name"] == "spray" for r in rows)


# -- the contract is the protocols ---------------------------------------------------------

class _Renderer:
    name = "raster"
    description = "A renderer with the required members only."

    def __call__(self, segments, widths, height, width):
        return None


class _Reader:
    name = "half-reader"
    description = "A reader without read()."

    def can_read(self, source: str) -> bool:
        return True


def test_an_object_missing_a_protocol_method_is_refused_naming_it() -> None:
    class Module:
        @hookimpl
        def inkmotion_readers(self):
            return [_Reader()]

    with pytest.raises(PluginError, match="the reader plugin 'half-reader' lacks read"):
        PluginHost().register(Module(), name="half")
    not_callable = type("NotCallable", (_Reader,), {"read": "not a method"})()
    assert check_plugin_object("reader", not_callable) == (
        "the reader plugin 'half-reader': read must be callable")


def test_optional_members_are_not_required() -> None:
    """A renderer without ``session``, a robot backend without ``replay``, a job kind
    without ``run_together`` or ``examples``: each registers; no optional member is among
    the required ones."""

    @dataclass
    class _Params:
        steps: int = 1

    class Kind:
        name, description, queue, inputs, Params = "bare-kind", "No extras.", "q", (), _Params

        def steps(self, params: object) -> int:
            return 1

        def run(self, job: object) -> dict:
            return {}

    class Backend:
        name, description = "bare-backend", "No replay."

        def execute(self, program: object, folder: object, **options: object) -> dict:
            return {}

    bare = type("Bare", (_Renderer,), {"name": "bare"})()
    for kind, obj in (("renderer", bare), ("robot-backend", Backend()), ("job-kind", Kind())):
        assert check_plugin_object(kind, obj) is None, kind
    for kind in PROTOCOLS:
        required, optional = protocol_members(PROTOCOLS[kind]), protocol_members(OPTIONAL[kind])
        assert not set(required) & set(optional), kind
    assert {"session", "renders_canvases"} <= set(protocol_members(OPTIONAL["renderer"]))
    assert "replay" in protocol_members(OPTIONAL["robot-backend"])
    assert {"run_together", "examples"} <= set(protocol_members(OPTIONAL["job-kind"]))


def test_the_check_follows_the_protocol(monkeypatch) -> None:
    """The members checked are the protocol's (bases included), methods callable; one
    added to a kind's protocol is required from then on."""
    assert set(PROTOCOLS) == set(OPTIONAL) == set(KIND_HOOKS)
    assert protocol_members(protocols.JobKind) == {
        "name": False, "description": False, "queue": False, "inputs": False,
        "Params": False, "steps": True, "run": True}
    assert protocol_members(protocols.Renderer) == {
        "__call__": True, "name": False, "description": False}

    class Erasing(protocols.Renderer, Protocol):
        brush: str

        def erase(self) -> None:
            """Clear the canvas."""

    monkeypatch.setitem(protocols.PROTOCOLS, "renderer", Erasing)
    assert check_plugin_object("renderer", _Renderer()) == (
        "the renderer plugin 'raster' lacks brush, erase")
    half = type("Half", (_Renderer,), {"brush": "soft", "erase": None})()
    assert check_plugin_object("renderer", half) == (
        "the renderer plugin 'raster': erase must be callable")
    whole = type("Whole", (_Renderer,), {"brush": "soft", "erase": lambda self: None})()
    assert check_plugin_object("renderer", whole) is None


def test_the_protocols_import_no_torch_and_the_objective_no_plugin_manager() -> None:
    """Engines take their hints from the protocols: importing them loads neither torch nor
    pluggy, and the objective does not pull in the plugin manager."""
    import subprocess

    code = ("import sys, {module}; print(sorted(n for n in sys.modules if n in "
            "('torch', 'pluggy', 'inkmotion.plugin_host.manager', "
            "'inkmotion.plugin_host.hookspecs')))")
    for module, expected in (("inkmotion.plugin_host.protocols", "[]"),
                             ("inkmotion.fitting.objective", "['torch']")):
        out = subprocess.run([sys.executable, "-c", code.format(module=module)],
                             capture_output=True, text=True, check=True)
        assert out.stdout.strip() == expected, (module, out.stdout)


# -- what a plugin declares must work on every command line ---------------------------------

def _losses_module(*losses: object) -> object:
    class Module:
        @hookimpl
        def inkmotion_image_losses(self):
            return list(losses)

    return Module()


def _loss(name: str, options: object = None, prepare: object = None) -> object:
    members = {"name": name, "description": f"The {name} loss."}
    if options is not None:
        members["Options"] = options
    members["prepare"] = prepare or (lambda self, reference, **options: None)
    return type(f"{name.title()}Loss", (), members)()


def test_an_option_flag_someone_else_has_is_refused_and_the_command_keeps_working() -> None:
    """A loss 'max' with an option 'error' would bring --max-error, run fit's own flag (it
    took `run fit` down with a duplicate-parameter traceback); a loss 'line' with an option
    'extent' would take the 'line' initialiser's --line-extent. Each is refused when it
    registers, naming the flag and its owner; the built-ins are untouched."""
    from inkmotion.jobs.params import param

    @dataclass
    class ErrorOptions:
        error: float = param(1.0, "Weight.")

    @dataclass
    class ExtentOptions:
        extent: float = param(9.0, "Extent.")

    h = PluginHost()
    h.load_entry_points()
    with pytest.raises(PluginError, match=r"the image-loss plugin 'max' .* would take the flag "
                                          r"--max-error, which the job kind 'fit' from "
                                          r"inkmotion \(inkmotion.plugins.fit\) already has"):
        h.register(_losses_module(_loss("max", ErrorOptions)), name="maxloss", origin="other")
    with pytest.raises(PluginError, match=r"--line-extent, which the initialiser plugin 'line' "
                                          r"from inkmotion"):
        h.register(_losses_module(_loss("line", ExtentOptions)), name="losses", origin="other")
    assert "max" not in h.plugins("image-loss") and "line" not in h.plugins("image-loss")
    h.register(_losses_module(_loss("wide", ErrorOptions)), name="wideloss", origin="other")
    assert "wide" in h.plugins("image-loss")  # --wide-error is nobody else's


@pytest.mark.parametrize("options, why", [
    (type("Plain", (), {"blur": 2.0}), r"Options must be a dataclass \(add @dataclass above "
                                        r"class Plain\)"),
    (dataclass(type("Bare", (), {"__annotations__": {"strength": float}})),
     r"Options field\(s\) strength have no default"),
])
def test_options_that_a_command_line_cannot_fill_are_refused(options, why) -> None:
    """Options that are no dataclass, or with a field that has no default, crashed `run fit
    --help` (or the job, with a TypeError) for everyone; now the plugin is refused."""
    with pytest.raises(PluginError, match=why):
        PluginHost().register(_losses_module(_loss("odd", options)), name="odd")


def test_a_method_that_cannot_take_what_inkmotion_passes_is_refused() -> None:
    """An initialiser whose __call__ takes no width/dtype/device keywords failed mid-job
    with "unexpected keyword argument 'width'"; a method that takes its options by name
    (every field of its Options is passed) is fine."""
    from inkmotion.jobs.params import param

    class NoKeywords:
        name, description = "nokw", "Takes the inputs only."

        def __call__(self, inputs):
            return []

    assert "__call__(inputs) cannot take what inkmotion passes it" in check_plugin_object(
        "initialiser", NoKeywords())
    assert "declare it as __call__(self, inputs, *, width, dtype, device, **options)" in \
        check_plugin_object("initialiser", NoKeywords())

    @dataclass
    class Strength:
        strength: float = param(1.0, "How strong.")

    named = _loss("named", Strength, prepare=lambda self, reference, strength: None)
    assert check_plugin_object("image-loss", named) is None
    assert "prepare(reference, strength)" in check_plugin_object(
        "image-loss", _loss("unnamed", prepare=lambda self, reference, strength: None))


def test_a_hook_that_returns_one_object_not_a_list_is_refused_saying_so() -> None:
    class Module:
        @hookimpl
        def inkmotion_image_losses(self):
            return _loss("single")

    with pytest.raises(PluginError, match=r"inkmotion_image_losses\(\) returned SingleLoss; "
                                          r"return a list of plugin objects"):
        PluginHost().register(Module(), name="single")


def test_the_built_ins_load_first_whatever_another_packages_entry_point_is_called(
        tmp_path, monkeypatch) -> None:
    """A third-party 'raster' renderer under the entry point 'aaa' (which sorts before
    the built-in's) used to register first and push the built-in out as the broken one;
    the built-ins load first, so the clash is the other package's."""
    _renderer_module(tmp_path / "tp_early.py", "raster", "A renderer that takes a built-in's "
                     "name.", "torch.ones(height, width)")
    info = tmp_path / "early_plugins-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: early-plugins\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[inkmotion]\naaa = tp_early\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    h = PluginHost()
    with pytest.warns(UserWarning, match="Two renderer plugins are named 'raster': one from "
                                         r"inkmotion \(inkmotion.plugins.raster\), one from "
                                         r"early-plugins"):
        h.load_entry_points()
    assert h.get("renderer", "raster")._inkmotion_origin.startswith("inkmotion (")
    assert [b.name for b in h.broken] == ["aaa"]
    sys.modules.pop("tp_early", None)


@pytest.mark.parametrize("given", ["spectral_saliency", "inkmotion.plugins.spectral_saliency",
                                   "spectral-saliency"])
def test_a_plugin_is_switched_off_by_the_module_its_origin_column_shows(
        monkeypatch, given: str) -> None:
    """The README says to name "the module in the origin column of `inkmotion plugins`",
    but only the entry-point name (spectral-saliency, shown nowhere) worked: the module's
    names warned "which no installed plugin has"."""
    import warnings

    monkeypatch.setenv("INKMOTION_DISABLE_PLUGINS", given)
    h = PluginHost()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        h.load_entry_points()
    assert [d.name for d in h.disabled] == ["spectral-saliency"]
    assert "spectral" not in h.plugins("saliency")
