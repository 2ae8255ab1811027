"""Layering (DESIGN.md, Packages): no import arrow runs upward or sideways between our packages."""

from __future__ import annotations

import ast

import pytest

from cosim.cli import commands, parser
from tests.conftest import ROOT

OURS = ("cosim", "coupler", "fluid_component", "solid_component", "fmu_component", "rom_component", "kratos_solvers",
        "cases", "workflow", "precice_compat", "kratos_compat")
ALLOWED = {"cosim": set(), "coupler": {"cosim"}, "fluid_component": {"cosim"}, "solid_component": {"cosim"},
           "fmu_component": {"cosim"}, "rom_component": {"cosim"}, "kratos_solvers": {"cosim"},
           # a case sits on everything it names: the coupler, the ROM, its solvers, the studies (the tube's stability
           # theory takes the Gauss-Seidel spectrum)
           "cases": {"cosim", "coupler", "rom_component", "fluid_component", "solid_component", "kratos_solvers",
                     "workflow"},
           # the studies over many runs (sweeps, stability matrices, campaigns) call the coupler's runs and the ROM's
           # training, export and report
           "workflow": {"cosim", "coupler", "rom_component"},
           # preCICE's cases read into scenes, above the coupler (its participant package imports none of ours)
           "precice_compat": {"cosim", "coupler"},
           # Kratos CoSimulation cases read into scenes, their solvers run by the Kratos stage driver
           "kratos_compat": {"cosim", "coupler", "kratos_solvers"}}


def imported_packages(path, packages=OURS) -> set[tuple[str, int]]:
    """The top-level ``packages`` (ours by default) imported anywhere in a module (in functions too), with line
    numbers."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        found |= {(name.split(".")[0], node.lineno) for name in names if name.split(".")[0] in packages}
    return found


@pytest.mark.parametrize("package", OURS)
def test_no_import_runs_upward_or_sideways(package):
    wrong = [f"{path.relative_to(ROOT)}:{line} imports {name}"
             for path in sorted((ROOT / package).rglob("*.py"))
             for name, line in imported_packages(path) if name != package and name not in ALLOWED[package]]
    assert wrong == []


def test_the_layering_check_catches_an_upward_import(tmp_path):
    module = tmp_path / "bad.py"
    module.write_text("def f():\n    from coupler.run import run_scene\n")
    assert imported_packages(module) == {("coupler", 2)}


def test_every_subcommand_is_registered_and_listed():
    assert set(commands()) == {"serve", "run", "check", "sweep", "stability", "train", "report", "export-fmu",
                               "campaign", "status", "plot", "keys", "libprecice"}
    text = parser().format_help()
    for name in commands():
        assert name in text


def test_the_studies_over_many_runs_are_the_workflow_s_and_the_coupler_holds_one_run():
    """Sweeps, stability matrices and campaigns, and their commands, are in workflow/; the coupler runs one scene (no
    module of it imports Dask or workflow, none is a study)."""
    from importlib.metadata import entry_points
    owners = {point.name: point.value.split(":")[0] for point in entry_points(group="cosim.commands")}
    assert {owners[name] for name in ("sweep", "stability", "campaign")} == {"workflow.commands"}
    assert {owners[name] for name in ("run", "check", "status", "plot")} == {"coupler.commands"}
    assert owners["libprecice"].startswith("precice_compat.libprecice")
    graph = module_graph(("coupler",))
    assert not {"coupler.sweep", "coupler.stability_matrix", "coupler.stability"} & set(graph)
    assert [path for path in sorted((ROOT / "coupler").rglob("*.py")) if imported_packages(path, ("dask",))] == []
    assert imported_packages(ROOT / "workflow" / "sweep.py", ("dask",))          # the check sees one


def test_results_paths_are_spelled_only_in_the_results_module():
    """Writer and reader share cosim/results.py's Layout; no other file spells an HDF5 path of the layout."""
    import re
    path_like = re.compile(r"""["'](/?)(windows|fields|snapshots|initial)/|["']components/|"/components""")
    spelled = [f"{path.relative_to(ROOT)}:{number}"
               for folder in (*OURS, "benchmarks", "scripts", "tests")
               for path in sorted((ROOT / folder).rglob("*.py")) if path != ROOT / "cosim" / "results.py"
               and path != ROOT / "tests" / "test_layering.py"
               for number, line in enumerate(path.read_text().splitlines(), 1) if path_like.search(line)]
    assert spelled == []


def test_the_tube_imports_no_kratos_nor_gmsh():
    """Everything a tube run loads, in the coupler and in its component modules, stays free of Kratos and gmsh (no
    package of Kratos's, nor ours around it; the coupler's own updates after Kratos's, coupler.accelerations.kratos,
    are NumPy)."""
    import subprocess
    import sys
    code = ("import sys; import cosim.cli, cosim.server, coupler.run, coupler.commands, fluid_component.tube, "
            "solid_component.tube, fmu_component.component, rom_component.static.component, rom_component.commands; "
            "from coupler.run import run_scene; from cosim.scene import load_scene; import tempfile, pathlib; "
            "d = pathlib.Path(tempfile.mkdtemp()); "
            "run_scene(load_scene('scenes/tube_fom.toml', ['time.end=0.3']), d / 'run', progress=False); "
            "print(sorted(m for m in sys.modules if 'kratos' in m.split('.')[0].lower() or m.split('.')[0] == 'gmsh'))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "[]"


def test_the_fmu_component_imports_fmpy_only_when_it_loads_an_fmu():
    """fmpy, an optional extra, is imported inside the functions that load an FMU, not with the modules."""
    import subprocess
    import sys
    code = ("import sys, fmu_component.component, fmu_component.archive, fmu_component.instance, "
            "fmu_component.fmi2_instance, fmu_component.fmi3_instance; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'fmpy'))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def module_graph(folders=OURS) -> dict[str, set[str]]:
    """Our modules and the modules of ours each imports (in functions too): ``from a.b import c`` names a.b.c
    when that is a module of ours, else a.b."""
    modules = {".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__"): path
               for folder in folders for path in (ROOT / folder).rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        edges = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                targets = [f"{node.module}.{alias.name}" if f"{node.module}.{alias.name}" in modules else node.module
                           for alias in node.names]
            else:
                continue
            edges |= {t for t in targets if t in modules and t != name}
        graph[name] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for nxt in graph.get(node, ()):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_no_import_cycle_between_our_modules():
    assert cycles(module_graph((*OURS, "benchmarks", "scripts"))) == []
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]   # the check sees one


def test_cosim_names_no_module_of_an_upper_package():
    """The bottom layer names no class or module above it, not even in a string: backends, commands and plots
    reach it as entry points."""
    import re
    upper = re.compile(r"\b(coupler|rom_component|solid_component|fmu_component|fluid_component|benchmarks|scripts)\.[a-z_]")
    named = [f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
             for path in sorted((ROOT / "cosim").rglob("*.py"))
             for number, line in enumerate(path.read_text().splitlines(), 1) if upper.search(line)]
    assert named == []


def test_make_demo_installs_the_tube_s_extras_only_and_the_kratos_targets_every_extra(tmp_path):
    """`make demo` on a fresh machine installs no Kratos and no gmsh (make -n prints what it would run)."""
    import shutil
    import subprocess
    if shutil.which("make") is None:
        pytest.skip("no make")

    def planned(target: str) -> str:
        done = subprocess.run(["make", "-n", target, f"VENV={tmp_path / 'venv'}"], cwd=ROOT, capture_output=True,
                              text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        return done.stdout
    demo = planned("demo")
    assert "-e '.[rom,fmu]'" in demo and "kratos" not in demo.lower() and "mesh" not in demo
    assert "scripts/tube_demo.sh" in demo
    for target in ("demo-flap", "mok", "test"):
        assert "kratos,mesh" in planned(target), target


ROM_FAMILIES = ("static", "dynamic")
ROM_SHARED = ("model_file", "model_check", "envelope", "parts", "recorded", "reduction", "native")


def rom_part(module: str) -> str:
    """The part of ``rom_component`` a module belongs to: a family, a shared module or folder, the FMU export, the
    report, or the top."""
    name = module.removeprefix("rom_component.")
    for part in (*ROM_FAMILIES, *ROM_SHARED, "fmu", "report"):
        if name == part or name.startswith(part + "."):
            return part
    return name


def test_the_rom_families_import_neither_each_other_nor_the_exports():
    """rom_component by family: the quasi-static ROM (static/) and the ROM with memory (dynamic/) import each other's
    modules nowhere; the shared modules (the model file, its checks, the parts, the reduction, the recorded data,
    the native runtime and its C build) import no family, no export and no report; the FMU export (fmu/) sits on the
    families and the native runtime, and only the export command imports it."""
    graph = module_graph(("rom_component",))
    wrong = [f"{module} imports {target}" for module, targets in sorted(graph.items()) for target in sorted(targets)
             if (rom_part(module) in ROM_FAMILIES and rom_part(target) in ROM_FAMILIES
                 and rom_part(target) != rom_part(module))
             or (rom_part(module) in ROM_SHARED and rom_part(target) in (*ROM_FAMILIES, "fmu", "report"))
             or (rom_part(target) == "fmu" and rom_part(module) not in ("fmu", "commands"))]
    assert wrong == []
    assert {rom_part(m) for m in graph} >= {*ROM_FAMILIES, "reduction", "native", "fmu", "report"}
    assert {"rom_component.native.build"} <= graph["rom_component.static.compiled"] & \
        graph["rom_component.dynamic.compiled"]


def test_the_schemes_drive_a_declared_protocol_and_name_no_surrogate():
    """The schemes ask what they drive through ``coupler.coupled.Coupled`` (no isinstance test, no getattr probe),
    and neither the schemes nor the run name the online surrogate: it is behind ``CouplingModel``."""
    import re
    schemes = (ROOT / "coupler" / "schemes.py").read_text()
    assert re.findall(r"\bisinstance\(|\bgetattr\(|\bhasattr\(", schemes) == []
    for module in ("schemes.py", "run.py", "run_observers.py"):
        assert "surrogate" not in (ROOT / "coupler" / module).read_text().lower(), module
