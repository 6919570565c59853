"""Layering: the model types live below io (old import paths still work), the compute modules do not
import io, datasets and io do not import each other both ways, only io writes files, and importing
millstab.plot leaves matplotlib's backend alone. Imports are read from the source (every ``import``,
also inside functions), so a lazy import counts as a dependency too."""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = SRC / "millstab"


def _module(path: Path) -> str:
    rel = path.relative_to(SRC).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


def _imports() -> dict[str, set[str]]:
    """{module: millstab modules it imports anywhere in its body}."""
    graph = {}
    for path in PKG.rglob("*.py"):
        mod = _module(path)
        out = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                out |= {a.name for a in node.names if a.name.startswith("millstab")}
            elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("millstab"):
                out.add(node.module)
                out |= {f"{node.module}.{a.name}" for a in node.names}  # `from millstab.io import points`
        graph[mod] = out
    return graph


@pytest.fixture(scope="module")
def graph():
    g = _imports()
    return {m: {d for d in deps if d in g} for m, deps in g.items()}


def _reaches(graph, start: str, prefix: str, exact: bool = False) -> list[str]:
    """A chain of imports from ``start`` to ``prefix`` or (unless ``exact``) a module under it ([] when none)."""
    seen, stack = {start}, [[start]]
    while stack:
        chain = stack.pop()
        for dep in sorted(graph.get(chain[-1], ())):
            if dep == prefix or (not exact and dep.startswith(prefix + ".")):
                return chain + [dep]
            if dep not in seen:
                seen.add(dep)
                stack.append(chain + [dep])
    return []


@pytest.mark.parametrize("module", ["millstab.model", "millstab.points", "millstab.config", "millstab.frf",
                                    "millstab.params", "millstab.forward", "millstab.identify.objective",
                                    "millstab.identify.synthetic", "millstab.plot"])
def test_model_and_compute_modules_do_not_import_io(graph, module):
    if module == "millstab.identify.synthetic":
        # example_points loads a packaged example through millstab.datasets (the one way up, on purpose)
        graph = {**graph, module: graph[module] - {"millstab.datasets"}}
    assert _reaches(graph, module, "millstab.io") == []


def test_io_does_not_import_datasets_and_io_has_no_circle(graph):
    for mod in graph:
        if mod.startswith("millstab.io"):
            assert _reaches(graph, mod, "millstab.datasets") == [], mod
            chain = _reaches(graph, mod, mod, exact=True)
            assert chain == [], chain


#: the doors: the only modules that may import the service layer (and themselves)
DOORS = ("millstab.cli", "millstab.web")


def test_only_the_doors_import_the_service_layer(graph):
    """api/ sits above every study and engine: nothing below it imports it, or a door."""
    for mod in graph:
        if mod.startswith(DOORS) or mod == "millstab.api" or mod.startswith("millstab.api."):
            continue
        for top in ("millstab.api",) + DOORS:
            assert _reaches(graph, mod, top) == [], (mod, top)


#: the engines and their compiled kernels: private to millstab.stability
ENGINE_MODULES = ("millstab.stability.zoa", "millstab.stability.sdm", "millstab.stability.spectral",
                  "millstab.stability._zoa_kernel", "millstab.stability._sdm_kernel",
                  "millstab.stability._spectral_kernel", "millstab.stability._spectral_warm")


def test_nothing_outside_the_engines_imports_a_specific_engine(graph):
    """Engines are leaves (issue 26): a consumer reaches one through the registry (``get_engine(name)``) and asks
    for capabilities; the shared helpers (``check_rpm``, ``directional_matrix``, the 2×2 closed forms in
    ``stability._linalg``) live in the contract, not in one engine. An import of an engine module or kernel
    from outside ``millstab.stability`` fails here."""
    for mod, deps in graph.items():
        if mod.startswith("millstab.stability"):
            continue
        direct = sorted(d for d in deps if d in ENGINE_MODULES)
        assert direct == [], (mod, direct)


def _consumer_nodes(pkg: Path):
    """(module, ast node) of every node of every module outside ``millstab.stability`` (the engines' consumers)."""
    for path in pkg.rglob("*.py"):
        mod = _module(path)
        if mod == "millstab.stability" or mod.startswith("millstab.stability."):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            yield mod, node


def _engines_by_name(pkg: Path) -> list[str]:
    """Calls ``get_engine("<literal name>")`` outside ``millstab.stability``: "module: name (line n)"."""
    return [f"{mod}: {node.args[0].value} (line {node.lineno})" for mod, node in _consumer_nodes(pkg)
            if (isinstance(node, ast.Call)
                and getattr(node.func, "id", getattr(node.func, "attr", None)) == "get_engine"
                and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str))]


def test_nothing_outside_the_engines_names_an_engine_to_get_it():
    """Engines are chosen by capability (issue 26): outside ``millstab.stability`` a consumer asks
    ``engine_with(cheap=True)`` or passes on the user's ``engine`` argument, never ``get_engine("zoa")``.
    A default argument value (``engine="zoa"``) is the user's choice and is allowed. Fails on the old code
    (api.identify, modal.run, reproduce ×5)."""
    assert _engines_by_name(PKG) == []


def test_the_engine_name_rule_catches_a_literal_name(tmp_path, monkeypatch):
    """The rule above is not vacuous: a literal name is reported (a bare or an attribute call), a variable is not,
    and the engines' own package may name its engines."""
    pkg = tmp_path / "millstab"
    (pkg / "api").mkdir(parents=True)
    (pkg / "stability").mkdir()
    (pkg / "api" / "x.py").write_text("import millstab.stability as st\nfrom millstab.stability import get_engine\n"
                                      "def f(engine='zoa'):\n    a = get_engine(engine)\n    b = get_engine('sdm')\n"
                                      "    return st.get_engine(\"zoa\")\n", encoding="utf-8")
    (pkg / "stability" / "__init__.py").write_text("get_engine('zoa')\n", encoding="utf-8")
    monkeypatch.setattr(sys.modules[__name__], "SRC", tmp_path)
    assert sorted(_engines_by_name(pkg)) == ["millstab.api.x: sdm (line 5)", "millstab.api.x: zoa (line 6)"]


def _engine_only_names() -> set[str]:
    """The public functions of the engine modules that are neither in the contract nor an optional capability
    (``stability.base.CONTRACT``, ``OPTIONAL``): an engine's own (``rho_map``, ``monodromy``, …)."""
    from millstab.stability.base import CONTRACT, OPTIONAL

    names = set()
    for mod in ("zoa", "sdm", "spectral"):
        tree = ast.parse((PKG / "stability" / f"{mod}.py").read_text(encoding="utf-8"))
        names |= {n.name for n in tree.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("_")}
    return names - set(CONTRACT) - set(OPTIONAL)


def _engine_only_uses(pkg: Path, names: set[str]) -> list[str]:
    """Uses ``x.<name>`` of an engine's own function outside ``millstab.stability``: "module: name (line n)"."""
    return [f"{mod}: {node.attr} (line {node.lineno})" for mod, node in _consumer_nodes(pkg)
            if isinstance(node, ast.Attribute) and node.attr in names]


def test_consumers_use_only_the_engine_contract_and_its_capabilities():
    """An engine got by capability is used only through the contract and the optional capabilities it declares
    (issue 26): reproduce/low_immersion called the sdm-only ``critical_multipliers`` on what
    ``engine_with(time_averaged=False, cheap=False)`` returned; it is now the optional capability
    ``reports_multipliers`` (fails on the old code: ``critical_multipliers`` was no capability)."""
    names = _engine_only_names()
    assert {"rho_map", "monodromy"} <= names and "critical_multipliers" not in names
    assert _engine_only_uses(PKG, names) == []


def test_the_contract_rule_catches_an_engine_s_own_function(tmp_path, monkeypatch):
    """The rule above is not vacuous: an engine's own function used outside the engines is reported."""
    pkg = tmp_path / "millstab"
    (pkg / "reproduce").mkdir(parents=True)
    (pkg / "reproduce" / "x.py").write_text("from millstab.stability import engine_with\n"
                                            "def f(s, c):\n    e = engine_with(cheap=False)\n"
                                            "    return e.envelope(s, c, [1.0]), e.rho_map(s, c, [1.0], [1e-3])\n",
                                            encoding="utf-8")
    names = _engine_only_names()
    monkeypatch.setattr(sys.modules[__name__], "SRC", tmp_path)
    assert _engine_only_uses(pkg, names) == ["millstab.reproduce.x: rho_map (line 4)"]


def test_engine_with_picks_the_engines_named_before():
    """Choosing by capability picks the same engines the consumers named before (results unchanged)."""
    from millstab.errors import InputError
    from millstab.stability import engine_with, get_engine

    assert engine_with(cheap=True) is get_engine("zoa")
    assert engine_with(accepts_measured_frf=True) is get_engine("zoa")
    assert engine_with(time_averaged=True) is get_engine("zoa")
    assert engine_with(time_averaged=False, cheap=False) is get_engine("sdm")
    assert engine_with(time_averaged=False, reports_multipliers=True) is get_engine("sdm")
    assert engine_with(time_averaged=False, reports_lobe_type=True) is get_engine("spectral")
    with pytest.raises(InputError, match="no registered engine"):
        engine_with(time_averaged=True, reports_lobe_type=True)


def _progress_aliases(pkg: Path) -> list[str]:
    """Module-level ``<Name>Progress = Callable[...]`` definitions: "module.Name"."""
    out = []
    for path in pkg.rglob("*.py"):
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if (isinstance(node, ast.Assign) and isinstance(node.value, ast.Subscript)
                    and getattr(node.value.value, "id", None) == "Callable"):
                out += [f"{_module(path)}.{t.id}" for t in node.targets
                        if isinstance(t, ast.Name) and t.id.endswith("Progress")]
    return sorted(out)


def test_the_progress_callbacks_are_defined_in_one_place(tmp_path, monkeypatch):
    """One name per thing (issue 26 item 7): the progress protocol and the two shapes that differ from it are
    defined in millstab/progress.py alone. Fails on the old code (api.progress.Progress, stability.sdm.Progress,
    identify.search.SolverProgress, sensitivity._core.CountProgress); a new definition elsewhere is caught."""
    assert _progress_aliases(PKG) == ["millstab.progress.CountProgress", "millstab.progress.Progress",
                                      "millstab.progress.SolverProgress"]
    (tmp_path / "millstab").mkdir()
    (tmp_path / "millstab" / "x.py").write_text("from typing import Callable\nMyProgress = Callable[[int], None]\n",
                                                encoding="utf-8")
    monkeypatch.setattr(sys.modules[__name__], "SRC", tmp_path)
    assert _progress_aliases(tmp_path / "millstab") == ["millstab.x.MyProgress"]
    import millstab.progress as home
    calls = []
    home.solver_progress(lambda *a: calls.append(a), "identify")("lsq", 3, 0.5)
    home.count_progress(lambda *a: calls.append(a), "sobol")(4, 10)
    assert calls == [("identify: lsq, best 0.5", 3, None), ("sobol", 4, 10)]


def test_plots_import_no_engine_and_no_study(graph):
    """Plots draw results: they import model types, never an engine or a study that computes."""
    for mod in graph:
        if mod.startswith("millstab.plot"):
            for below in ("millstab.stability", "millstab.forward", "millstab.identify", "millstab.update",
                          "millstab.sensitivity", "millstab.simulate", "millstab.api"):
                assert _reaches(graph, mod, below) == [], (mod, below)


def test_old_import_paths_still_work():
    from millstab.config import PriorTable
    from millstab.io.config import PriorTable as IoPrior
    from millstab.io.points import check_enough
    from millstab.points import check_enough as new_check

    assert check_enough is new_check and IoPrior is PriorTable


#: one home per type (issue 26 item 7): the model types io reads, imported from where they are defined
ONE_HOME = {"Config": "millstab.config", "PointSet": "millstab.points"}


def _imports_away_from_home(roots: list[Path]) -> list[str]:
    """``from M import Config`` / ``PointSet`` with M not the type's home, in .py files and the ```python blocks of
    .md files under ``roots``: "file: M.Name (line n)"."""
    out = []
    for root in roots:
        for path in sorted(root.rglob("*.py")) + sorted(root.rglob("*.md")):
            text = path.read_text(encoding="utf-8")
            blocks = ([text] if path.suffix == ".py" else
                      [b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S)])
            for block in blocks:
                try:
                    tree = ast.parse(block)
                except SyntaxError:
                    continue
                for node in ast.walk(tree):
                    if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("millstab"):
                        out += [f"{path.name}: {node.module}.{a.name} (line {node.lineno})" for a in node.names
                                if a.name in ONE_HOME and node.module != ONE_HOME[a.name]]
    return out


def test_config_and_pointset_are_imported_from_their_one_home(tmp_path):
    """Config and PointSet are defined below io and imported from there only: io does not re-export them, and
    src/, tests/, benchmarks/ and docs/ import them from millstab.config / millstab.points. Fails on the old
    code (millstab.io re-exported both; 49 imports went through io)."""
    import millstab.io

    root = SRC.parent
    assert not {"Config", "PointSet"} & set(dir(millstab.io))
    assert _imports_away_from_home([root / "src", root / "tests", root / "benchmarks", root / "docs"]) == []
    (tmp_path / "x.py").write_text("from millstab.io import Config\nfrom millstab.points import PointSet\n",
                                   encoding="utf-8")
    (tmp_path / "y.md").write_text("```python\nfrom millstab.io.points import PointSet\n```\n", encoding="utf-8")
    assert _imports_away_from_home([tmp_path]) == ["x.py: millstab.io.Config (line 1)",
                                                   "y.md: millstab.io.points.PointSet (line 1)"]


def test_only_io_writes_files():
    """Outside io/ no module opens a file for writing, saves a figure or makes a folder itself."""
    bad = []
    for path in PKG.rglob("*.py"):
        if path.is_relative_to(PKG / "io"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
                name = node.func.attr
                if name in ("savefig", "write_text", "write_bytes", "mkdir", "makedirs"):
                    bad.append(f"{path.relative_to(SRC)}:{node.lineno} {name}")
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "open":
                modes = [a.value for a in node.args[1:2] if isinstance(a, ast.Constant)]
                modes += [k.value.value for k in node.keywords if k.arg == "mode" and isinstance(k.value, ast.Constant)]
                if any(set(m) & set("wax+") for m in modes):
                    bad.append(f"{path.relative_to(SRC)}:{node.lineno} open({modes[0]!r})")
    assert bad == []


def _run(code: str) -> str:
    env = {k: v for k, v in os.environ.items() if k not in ("MPLBACKEND", "DISPLAY", "WAYLAND_DISPLAY")}
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), env.get("PYTHONPATH", "")])
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


@pytest.mark.slow
def test_importing_plot_keeps_the_backend():
    """A backend chosen before (a notebook's) stays; with none chosen, none is forced (it was Agg)."""
    code = ("import matplotlib\n"
            "matplotlib.use('svg')\n"
            "import millstab.plot, millstab.plot.sld, millstab.plot.identify, millstab.plot.sensitivity\n"
            "print(matplotlib.get_backend())\n")
    assert _run(code) == "svg"
    code = ("import matplotlib\n"
            "import millstab.plot, millstab.plot.sld, millstab.plot.engines, millstab.plot.update\n"
            "print(matplotlib.rcParams._get_backend_or_none())\n")
    assert _run(code) == "None"


def test_a_figure_saves_without_a_display(tmp_path):
    """Headless (no DISPLAY, no MPLBACKEND): a plot's figure is written by io.save_figure and closed."""
    out = tmp_path / "f.png"
    code = ("import numpy as np, matplotlib.pyplot as plt\n"
            "from millstab.plot.engines import plot_engine_panels\n"
            "from millstab.io import save_figure\n"
            "r = np.linspace(5000, 9000, 5)\n"
            f"save_figure(plot_engine_panels([{{'title': 't', 'curves': {{'a': (r, r / 1e3)}}}}]), {str(out)!r})\n"
            "print(len(plt.get_fignums()))\n")
    assert _run(code) == "0"
    assert out.read_bytes()[:4] == b"\x89PNG"


#: what a door may import besides itself: the service layer, the errors and the file layer (issue 26)
DOOR_MAY_IMPORT = ("millstab.api", "millstab.errors", "millstab.io")


def _door_imports() -> dict[str, list[str]]:
    """{door module: the millstab modules it imports that are not itself, another door, api, errors or io}.
    ``from millstab import api`` counts as importing ``millstab.api``."""
    bad = {}
    for path in PKG.rglob("*.py"):
        mod = _module(path)
        if not mod.startswith(DOORS):
            continue
        out = []
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = ([f"{node.module}.{a.name}" for a in node.names] if node.module == "millstab"
                         else [node.module])
            for name in names:
                if not name.startswith("millstab"):
                    continue
                if any(name == top or name.startswith(top + ".") for top in DOOR_MAY_IMPORT + DOORS):
                    continue
                out.append(f"{name} (line {node.lineno})")
        if out:
            bad[mod] = out
    return bad


def test_the_doors_import_only_the_services_errors_and_io():
    """cli/ and web/ are doors: they parse, call millstab.api, print or show, and save through io. A door that
    imports a study, an engine, the model or a parser directly has logic the other door lacks (issue 26)."""
    assert _door_imports() == {}


#: the libraries a door may use besides the standard library: the command line's (typer, rich, and numba only to
#: announce a cold compile cache), the app's (Panel and what it draws with); numpy only where the app hands arrays
#: to bokeh; tornado (Panel's server) only to read the login's signed cookie. A door that needs numpy to compute
#: something has logic of a service.
DOOR_LIBRARIES = {"millstab.cli": {"typer", "rich", "click", "panel", "numba"},
                  "millstab.web": {"panel", "param", "bokeh", "numpy", "tornado"}}


def test_the_doors_use_only_their_own_libraries():
    bad = []
    for path in PKG.rglob("*.py"):
        mod = _module(path)
        door = next((d for d in DOOR_LIBRARIES if mod == d or mod.startswith(d + ".")), None)
        if door is None:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module] if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 else [])
            for name in names:
                top = name.split(".")[0]
                if top not in sys.stdlib_module_names and top != "millstab" and top not in DOOR_LIBRARIES[door]:
                    bad.append(f"{mod}: {name} (line {node.lineno})")
    assert bad == []


def test_the_door_rule_catches_a_door_importing_below_the_services(tmp_path, monkeypatch):
    """The rule above is not vacuous: a door module importing an engine's registry is reported."""
    pkg = tmp_path / "millstab"
    (pkg / "cli").mkdir(parents=True)
    (pkg / "cli" / "x.py").write_text("from millstab import api\nfrom millstab.io import write_json\n"
                                      "def f():\n    from millstab.stability import ENGINES\n", encoding="utf-8")
    monkeypatch.setattr(sys.modules[__name__], "PKG", pkg)
    monkeypatch.setattr(sys.modules[__name__], "SRC", tmp_path)
    assert _door_imports() == {"millstab.cli.x": ["millstab.stability (line 4)"]}


def test_the_service_layer_resolves_every_name_to_the_task_not_its_module():
    """``millstab.api`` imports a name's submodule on first use; a submodule that shares its name with a task
    (``api.identify``, ``api.update``, ...) must still leave ``api.identify`` the function, whichever is
    imported first."""
    import importlib
    import types

    from millstab import api

    for mod in ("identify", "update", "lobes", "predict", "validate", "sensitivity", "studies", "inputs"):
        importlib.import_module(f"millstab.api.{mod}")
    for name in api.__all__:
        value = getattr(api, name)
        assert not isinstance(value, types.ModuleType), name
    assert callable(api.identify) and callable(api.update) and "zoa" in api.ENGINES
    assert isinstance(api.inputs, types.ModuleType) and api.inputs.MAX_TEXT_BYTES > 0  # a submodule by its name
    with pytest.raises(AttributeError):
        api.no_such_task  # noqa: B018


def test_importing_the_service_layer_and_the_cli_imports_no_scipy_and_no_numba():
    """The doors import ``millstab.api`` at module level (issue 26); it must stay as cheap as before (the CLI
    starts without scipy and numba, which its commands import when they run)."""
    code = ("import sys, millstab.api, millstab.cli\n"
            "print(sorted(m for m in ('scipy', 'numba', 'matplotlib') if m in sys.modules))\n")
    assert _run(code) == "[]"


def test_the_doors_reach_the_shop_database_through_the_service_layer_only(graph):
    """The app and the commands read and write campaigns through millstab.api.shop (which enforces the
    per-shop rule, issue 31.4), never through millstab.shopdb directly."""
    for mod, deps in graph.items():
        if mod.startswith(DOORS):
            assert sorted(d for d in deps if d == "millstab.shopdb" or d.startswith("millstab.shopdb.")) == [], mod


# --- thin doors (issue 26): every function of cli/ is short ---------------------------------------------------
#: the longest a function of cli/ may be: statements after its docstring, blank and comment lines not counted.
#: A command parses, calls one service, prints and saves (cli/emit.py); more is logic of a service.
DOOR_BODY_LIMIT = 25
#: functions allowed longer, with their length today as a ceiling (a body may shrink, never grow) and the reason
DOOR_BODY_ALLOWED = {
    # one except clause per kind of failure (input error, missing file, memory, the last resort): the door's own job
    "millstab.cli.main": 29,
}


def _door_bodies(pkg: Path | None = None) -> dict[str, int]:
    """{module.function: counted lines} of every function in cli/ (methods and nested functions included)."""
    out = {}
    for path in sorted((pkg or PKG / "cli").rglob("*.py")):
        mod = _module(path)
        src = path.read_text(encoding="utf-8").splitlines()
        for node in ast.walk(ast.parse("\n".join(src))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                body = body[1:]  # the docstring
            if not body:
                continue
            lines = src[body[0].lineno - 1:body[-1].end_lineno]
            out[f"{mod.removesuffix('.__init__')}.{node.name}"] = sum(
                1 for t in lines if t.strip() and not t.strip().startswith("#"))
    return out


def test_every_command_body_is_short():
    """The typer commands of cli/ (and every helper beside them, so that logic cannot hide in one) have at most
    DOOR_BODY_LIMIT lines: parse, one api call, print and save. Fails on the old code (update 73 lines, identify
    59, simulate 58, design 46, recommend 44, ...)."""
    bodies = _door_bodies()
    assert "millstab.cli.update.update_cmd" in bodies and "millstab.cli.lobes.lobes" in bodies  # the walk sees them
    long = {name: n for name, n in bodies.items() if n > DOOR_BODY_ALLOWED.get(name, DOOR_BODY_LIMIT)}
    assert long == {}, f"move the logic into millstab.api or the studies: {long}"
    stale = {name for name in DOOR_BODY_ALLOWED if bodies.get(name, 0) <= DOOR_BODY_LIMIT}
    assert not stale, f"no longer long: drop from DOOR_BODY_ALLOWED {stale}"
