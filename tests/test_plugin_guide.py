"""The plugin guide's own example (docs/plugins.md) is real code: its pyproject.toml names
the module in the entry-point group under the plugin's name, and its module registers, is
checked by the host, and gives a differentiable loss with its declared option."""

from __future__ import annotations

import re
import sys
import types
from pathlib import Path

import torch

from inkmotion.jobs.params import describe
from inkmotion.plugin_host.manager import PluginHost
from inkmotion.plugin_host.protocols import Reference

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

GUIDE = Path(__file__).parents[1] / "docs" / "plugins.md"


def blocks(language: str) -> list[str]:
    return [b for lang, b in re.findall(r"```(\w+)\n(.*?)```", GUIDE.read_text(), re.S)
            if lang == language]


def test_the_guides_pyproject_is_complete() -> None:
    (toml,) = [b for b in blocks("toml") if "build-system" in b]
    project = tomllib.loads(toml)
    assert project["build-system"]["build-backend"] == "setuptools.build_meta"
    assert project["project"]["entry-points"]["inkmotion"] == {"stipple": "inkmotion_stipple"}
    assert project["tool"]["setuptools"]["py-modules"] == ["inkmotion_stipple"]


def test_the_guides_loss_registers_and_works(monkeypatch) -> None:
    (code,) = [b for b in blocks("python") if "class StippleLoss" in b]
    module = types.ModuleType("inkmotion_stipple")
    monkeypatch.setitem(sys.modules, "inkmotion_stipple", module)  # as if imported
    exec(compile(code, str(GUIDE), "exec"), module.__dict__)
    host = PluginHost()
    host.register(module, name="stipple", origin="docs/plugins.md")
    loss_plugin = host.get("image-loss", "stipple")
    assert [i.name for i in describe(loss_plugin.Options)] == ["blur"]

    target = torch.zeros(32, 32, dtype=torch.float64)
    target[10:20, 10:20] = 1.0
    loss = loss_plugin.prepare(Reference(image=target), blur=2.0)
    inside = torch.zeros_like(target)
    inside[12:18, 12:18] = 1.0
    outside = torch.zeros_like(target)
    outside[0:6, 24:30] = 1.0
    assert float(loss(outside)) > 5 * float(loss(inside))  # ink away from the target costs
    rendered = outside.clone().requires_grad_(True)
    loss(rendered).backward()
    assert rendered.grad is not None and rendered.grad.abs().sum() > 0
