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
