"""A parameter followed from the command line to an engine goes down the layers (issue 26, "What it must
reach"): ``millstab sensitivity oat`` run through typer's CliRunner with distinctive values (speeds, a relative
change, a plug-in engine's name) reaches the engine's entry unchanged, through doors → api → studies →
forward → stability, and the modules on that path import only their own layer or the ones below."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import numpy as np
import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

#: the layers from the top (docs/architecture.md): a module's layer is its longest matching prefix
LAYERS = {"millstab.cli": 0, "millstab.web": 0, "millstab.api": 1,
          **{f"millstab.{s}": 2 for s in ("identify", "update", "sensitivity", "simulate", "modal", "listen",
                                           "reproduce", "cluster", "shopdb")},
          "millstab.forward": 3, "millstab.stability": 4,
          **{f"millstab.{s}": 5 for s in ("model", "frf", "params", "points", "config", "units", "progress", "parsing",
                                           "bounds", "errors", "frfkind", "tooltip", "jsondoc", "warnlog")}}
#: beside the layers: files (io, the packaged datasets), used by the studies and above, never by the forward
#: function, an engine or the model; figures (plot) may be drawn from any result (``figure()``, imported lazily),
#: since plot itself imports the model alone (checked below)
SIDE = {"millstab.io": 2, "millstab.datasets": 2}


def _layer(mod: str, table: dict) -> int | None:
    hits = [p for p in table if mod == p or mod.startswith(p + ".")]
    return table[max(hits, key=len)] if hits else None


def _module_of(path: Path) -> str:
    rel = path.relative_to(SRC).with_suffix("")
    return ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)


def _imports(mod: str) -> set[str]:
    """The millstab modules ``mod`` imports anywhere in its body (lazy imports count)."""
    parts = mod.split(".")
    path = SRC.joinpath(*parts).with_suffix(".py")
    if not path.exists():
        path = SRC.joinpath(*parts, "__init__.py")
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("millstab")}
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("millstab"):
            out.add(node.module)  # and `from millstab import cluster`: the module named (a plain name adds nothing)
            out |= {f"{node.module}.{a.name}" for a in node.names if _is_module(f"{node.module}.{a.name}")}
    return out


def _is_module(name: str) -> bool:
    parts = name.split(".")
    return SRC.joinpath(*parts).with_suffix(".py").exists() or SRC.joinpath(*parts, "__init__.py").exists()


def climbs(mod: str) -> list[str]:
    """The imports of ``mod`` that point up: to a higher layer, or to io/datasets from below the studies; plot may
    import the model alone."""
    own = 5 if mod.startswith("millstab.plot") else _layer(mod, LAYERS)
    bad = []
    for dep in sorted(_imports(mod)):
        if dep == "millstab":
            continue
        up = _layer(dep, LAYERS)
        side = _layer(dep, SIDE)
        if (up is not None and up < own) or (side is not None and own > side):
            bad.append(dep)
    return bad


@pytest.fixture
def tracer():
    """A plug-in engine (zoa under another name) whose batched entry records what reaches it and from where."""
    from plugin_engines import zoa_plugin

    from millstab import stability as stab

    zoa = stab.get_engine("zoa")
    seen: list[dict] = []
    m = zoa_plugin("tracer")

    def envelope_batch(batch, cutting, rpm, **kw):
        stack = [f.frame.f_globals.get("__name__", "") for f in inspect.stack()[1:]]
        seen.append({"batch": batch, "cutting": cutting, "rpm": np.array(rpm, dtype=float),
                     "path": [s for s in reversed(stack) if s.startswith("millstab.")]})
        return zoa.envelope_batch(batch, cutting, rpm, **kw)

    m.envelope_batch = envelope_batch
    stab.register(m)
    yield seen
    stab.unregister("tracer")


def test_a_cli_parameter_reaches_the_engine_unchanged_down_the_layers(tracer):
    """Speeds 7001:7013:6, a relative change of 7.31 % and the engine "tracer" given on the command line arrive
    at the engine's entry as written: the speeds [7001, 7007, 7013] rev/min, a row with fn_x = 1.0731 × the
    config's (Example 1) beside the config's own, Kt as the config says; the call came down cli → api →
    sensitivity → forward without climbing back, and no module on that path imports a layer above it."""
    from typer.testing import CliRunner

    import millstab.cli  # noqa: F401 - registers every command on the app
    from millstab.cli.app import app
    from millstab.io import load_config

    res = CliRunner().invoke(app, ["sensitivity", "oat", "example:ex1", "--rpm", "7001:7013:6", "--eps", "0.0731",
                                   "--engine", "tracer"])
    assert res.exit_code == 0, res.output
    assert tracer, "the engine was never called"
    cfg = load_config("example:ex1")
    fn_x = cfg.structure.x[0].fn
    for call in tracer:
        np.testing.assert_array_equal(call["rpm"], [7001.0, 7007.0, 7013.0])
        assert call["cutting"].kt == cfg.cutting.kt
    rows = np.concatenate([c["batch"].fn_x[:, 0] for c in tracer])
    assert np.any(rows == fn_x) and np.any(np.isclose(rows, fn_x * 1.0731, rtol=1e-15, atol=0))
    path = tracer[0]["path"]
    layers = [_layer(m, LAYERS) for m in path]
    assert path[0].startswith("millstab.cli") and path[-1] == "millstab.forward", path
    assert {0, 1, 2, 3} <= set(layers) and layers == sorted(layers), list(zip(path, layers))
    assert {m: climbs(m) for m in set(path)} == {m: [] for m in set(path)}


def test_no_module_of_the_layers_imports_a_layer_above_it():
    """The static half over all of src/ (ast, lazy imports included): every module of a layer imports only its
    own layer and those below (io and the datasets from the studies up; plot only the model), so whichever
    command a parameter comes from, its path can only go down."""
    found = {}
    for path in (SRC / "millstab").rglob("*.py"):
        mod = _module_of(path)
        if _layer(mod, LAYERS) is not None or mod.startswith("millstab.plot"):
            found[mod] = climbs(mod)
    assert len(found) > 100 and {m: c for m, c in found.items() if c} == {}


def test_the_climb_rule_catches_an_import_upwards(monkeypatch):
    """The static rule is not vacuous: a study importing the service layer, the forward module importing a
    study, an engine importing io and a plot importing an engine are reported; an engine importing the model and
    a study reading files through io are not."""
    fake = {"millstab.sensitivity.x": {"millstab.api", "millstab.model"}, "millstab.forward": {"millstab.update.prior"},
            "millstab.update.y": {"millstab.io.config"}, "millstab.stability.z": {"millstab.model", "millstab.frf"},
            "millstab.stability.w": {"millstab.io.results"}, "millstab.plot.v": {"millstab.stability.zoa"}}
    monkeypatch.setitem(globals(), "_imports", lambda mod: fake[mod])
    assert climbs("millstab.sensitivity.x") == ["millstab.api"]
    assert climbs("millstab.forward") == ["millstab.update.prior"]
    assert climbs("millstab.update.y") == []  # a study may read files through io
    assert climbs("millstab.stability.z") == []
    assert climbs("millstab.stability.w") == ["millstab.io.results"]
    assert climbs("millstab.plot.v") == ["millstab.stability.zoa"]
