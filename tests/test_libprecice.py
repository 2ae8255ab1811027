"""cosim's libprecice: preCICE's C++, C and Fortran APIs served by cosim's coupler. Participants written here, built
as adapters build (CMake's find_package(precice 3 CONFIG), pkg-config), coupled to Python participants and to each
other through real processes: the tube's wall in three languages against the native run bit for bit, the install's
layout, and how a compiled participant's misuse, crash or hang stops a run."""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from cosim.errors import CosimError
from tests.conftest import ROOT, children_of
from tests.test_precice import EXAMPLE, case, native, same_run

SOURCE = ROOT / "precice_compat" / "libprecice"
DATA = ROOT / "tests" / "data" / "libprecice"
needs_fortran = pytest.mark.skipif(shutil.which("gfortran") is None, reason="needs gfortran (Debian: gfortran)")


def _sources_digest() -> str:
    digest = hashlib.sha256()
    for path in sorted(p for p in SOURCE.rglob("*") if p.is_file() and p.suffix in (".cpp", ".hpp", ".h", ".in", ".txt")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


@pytest.fixture(scope="session")
def prefix(tmp_path_factory) -> Path:
    """The drop-in built and installed once for the whole session (every xdist worker shares it), in a prefix of
    its own."""
    from precice_compat.libprecice.build import install, installed, missing_tools
    missing = missing_tools()
    if missing:
        pytest.skip(f"cosim libprecice needs {', '.join(missing)} (Debian: g++ cmake pkg-config libzmq3-dev "
                    "libmsgpack-dev)")
    root = tmp_path_factory.getbasetemp().parent / f"libprecice-{_sources_digest()}"
    root.mkdir(exist_ok=True)
    with open(root / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if installed(root / "prefix") is None:
            install(root / "prefix", build=root / "build", quiet=True)
    return root / "prefix"


@pytest.fixture
def served(prefix, monkeypatch) -> Path:
    """cosim run finds the drop-in where the session installed it (as it finds one in its Python environment)."""
    import precice_compat.case
    monkeypatch.setattr(precice_compat.case, "installed", lambda: prefix)
    return prefix


def cmake_build(source: Path, build: Path, prefix: Path, target: str) -> Path:
    """``source`` built with its CMakeLists (find_package(precice 3 CONFIG) against ``prefix``): the target."""
    for step in (["cmake", "-S", str(source), "-B", str(build), f"-DCMAKE_PREFIX_PATH={prefix}"],
                 ["cmake", "--build", str(build)]):
        done = subprocess.run(step, capture_output=True, text=True)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return build / target


def pkg_config_build(source: Path, out: Path, prefix: Path, compiler: str = "cc") -> Path:
    """``source`` compiled and linked by the flags pkg-config gives for libprecice (no rpath: the library is found
    on the library path cosim run sets)."""
    env = {**os.environ, "PKG_CONFIG_PATH": str(prefix / "lib" / "pkgconfig")}
    flags = subprocess.run(["pkg-config", "--cflags", "--libs", "libprecice"], capture_output=True, text=True,
                           env=env, check=True).stdout.split()
    done = subprocess.run([compiler, "-O2", "-ffp-contract=off", "-o", str(out), str(source), *flags, "-lm"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    return out


@pytest.fixture(scope="module")
def native_run(tmp_path_factory) -> Path:
    return native(tmp_path_factory.mktemp("native") / "run")


def solid(language: str, tmp_path: Path, prefix: Path) -> Path:
    if language == "cpp":
        return cmake_build(EXAMPLE / "solid-cpp", tmp_path / "build", prefix, "SolidSolver")
    if language == "c":
        return pkg_config_build(EXAMPLE / "solid-c" / "SolidSolver.c", tmp_path / "SolidSolver", prefix)
    if shutil.which("gfortran") is None:
        pytest.skip("needs gfortran (Debian: gfortran)")
    return cmake_build(EXAMPLE / "solid-fortran", tmp_path / "build", prefix, "SolidSolver")


@pytest.mark.parametrize("language", ["cpp", "c", "fortran"])
def test_the_tube_wall_in_cpp_c_and_fortran_gives_the_native_run_bit_for_bit(served, native_run, tmp_path, language):
    """examples/precice_tube/solid-{cpp,c,fortran}: the wall in each language, built against the drop-in with
    CMake (C++, Fortran) or pkg-config (C), coupled to the Python fluid participant: every window's iterations,
    field and residual equal to the native tube run's."""
    executable = solid(language, tmp_path, served)
    out = case(tmp_path / "run", EXAMPLE / "case.toml", f"participants.Solid.command={executable} ../precice-config.xml")
    same_run(native_run, out)
    assert children_of(os.getpid()) == []


def test_the_install_is_laid_out_as_precices(prefix, tmp_path):
    """libprecice.so -> .so.3 -> .so.3.4.1 with SONAME libprecice.so.3, the headers preCICE installs, pkg-config's
    libprecice at 3.4.1, and CMake's package: find_package(precice 3) found, precice 4 refused."""
    lib = prefix / "lib"
    assert os.readlink(lib / "libprecice.so") == "libprecice.so.3"
    assert os.readlink(lib / "libprecice.so.3") == "libprecice.so.3.4.1"
    dynamic = subprocess.run(["readelf", "-d", str(lib / "libprecice.so.3.4.1")], capture_output=True, text=True)
    if dynamic.returncode == 0:
        assert "Library soname: [libprecice.so.3]" in dynamic.stdout
    headers = {p.name for p in (prefix / "include" / "precice").iterdir()}
    assert {"precice.hpp", "Participant.hpp", "Types.hpp", "span.hpp", "Exceptions.hpp", "Version.h", "export.h",
            "preciceC.h", "preciceFortran.hpp", "Tooling.hpp"} <= headers
    env = {**os.environ, "PKG_CONFIG_PATH": str(lib / "pkgconfig")}
    version = subprocess.run(["pkg-config", "--modversion", "libprecice"], capture_output=True, text=True, env=env)
    assert version.stdout.strip() == "3.4.1"
    for wanted, found in (("3", True), ("4", False)):
        project = tmp_path / f"v{wanted}"
        project.mkdir()
        (project / "CMakeLists.txt").write_text(
            f"cmake_minimum_required(VERSION 3.16)\nproject(p LANGUAGES C)\nfind_package(precice {wanted} CONFIG)\n"
            "message(STATUS \"found=${precice_FOUND} cosim=${precice_SERVED_BY_COSIM}\")\n")
        done = subprocess.run(["cmake", "-S", str(project), "-B", str(project / "build"),
                               f"-DCMAKE_PREFIX_PATH={prefix}"], capture_output=True, text=True)
        assert ("found=1 cosim=TRUE" in done.stdout) == found, done.stdout + done.stderr


def program_build(name: str, language: str, tmp_path: Path, prefix: Path) -> Path:
    """tests/data/libprecice/NAME.{cpp,c,f90} built against ``prefix``: C++ with CMake, C and Fortran by pkg-config."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    if language == "cpp":
        (tmp_path / "src").mkdir()
        shutil.copy(DATA / f"{name}.cpp", tmp_path / "src")
        (tmp_path / "src" / "CMakeLists.txt").write_text(
            f"cmake_minimum_required(VERSION 3.16)\nproject({name} LANGUAGES CXX)\nfind_package(precice 3 REQUIRED "
            f"CONFIG)\nadd_executable({name} {name}.cpp)\ntarget_link_libraries({name} PRIVATE precice::precice)\n")
        return cmake_build(tmp_path / "src", tmp_path / "build", prefix, name)
    if language == "c":
        return pkg_config_build(DATA / f"{name}.c", tmp_path / name, prefix)
    if shutil.which("gfortran") is None:
        pytest.skip("needs gfortran (Debian: gfortran)")
    return pkg_config_build(DATA / f"{name}.f90", tmp_path / name, prefix, compiler="gfortran")


@pytest.mark.parametrize("language, what, message", [
    ("cpp", "values", r"component 'Solid' in window 3 .*: Participant::writeData: 100 values for 101 vertices of "
                      r"scalar data 'CrossSectionLength'; expected 101$"),
    ("cpp", "caught", r"Participant::advance: the step -1 must be positive$"),
    ("cpp", "read-time", r"Participant::readData: relativeReadTime 0.2 is outside the step \(0 to 0.1, what is left "
                         r"of the window\)$"),
    ("c", "before-create", r"precicec_initialize: no participant: create it first \(precicec_createParticipant or "
                           r"precicef_create\)$"),
    ("c", "name", r"precicec_writeData: participant 'Solid' uses no mesh 'Solid-Mesh' \(its meshes: Fluid-Nodes, "
                  r"Solid-Nodes\)$"),
    ("fortran", "read", r"precicef_read_data: participant 'Solid' uses no data 'Section' on mesh 'Solid-Nodes' \(it "
                        r"uses: CrossSectionLength on Solid-Nodes, Pressure on Solid-Nodes\)$"),
])
def test_a_compiled_participants_misuse_stops_the_run_in_one_line_naming_the_call(served, tmp_path, language, what,
                                                                                  message):
    """A misuse stops the run with its line, caught or not; left uncaught in C++ (and always in C and Fortran) it
    ends the participant as preCICE ends one: the line on stderr, exit code 2. Nothing is left running."""
    executable = program_build("misuse", language, tmp_path, served)
    with pytest.raises(CosimError, match=message) as raised:
        case(tmp_path / "run", EXAMPLE / "case.toml", f"participants.Solid.command={executable} ../precice-config.xml "
                                                      f"{what}")
    assert "\n" not in str(raised.value)
    if what != "caught":        # the participant's own line: the run's, after its "component ... :" prefix
        last = (tmp_path / "run" / "logs" / "Solid.log").read_text().strip().splitlines()[-1]
        assert last.startswith("precice: error: ") and str(raised.value).endswith(last[len("precice: error: "):])
    assert children_of(os.getpid()) == []


@pytest.mark.parametrize("what, message", [
    ("crash", r"component 'Solid' in window 3 .*(died|signal|SIGABRT|code -6)"),
    ("exit", r"component 'Solid' in window 3 .*: exited \(code 0\) while the coupler waited for advance"),
    ("hang", r"component 'Solid' in window 3 .*: did not call advance within 2 s"),
])
def test_a_compiled_participant_that_crashes_exits_or_hangs_stops_the_run_naming_it(served, tmp_path, what, message):
    executable = program_build("misuse", "cpp", tmp_path, served)
    with pytest.raises(CosimError, match=message):
        case(tmp_path / "run", EXAMPLE / "case.toml",
             f"participants.Solid.command={executable} ../precice-config.xml {what}", "participants.Solid.timeout=2")
    assert children_of(os.getpid()) == []


def test_a_participant_that_returns_without_finalize_is_finalized_by_the_destructor(served, tmp_path):
    """As preCICE's destructor: the run ends with every window converged."""
    from cosim.results import RunResults
    executable = program_build("misuse", "cpp", tmp_path, served)
    out = case(tmp_path / "run", EXAMPLE / "case.toml",
               f"participants.Solid.command={executable} ../precice-config.xml no-finalize")
    with RunResults(out) as results:
        assert len(results.windows.time) == 20 and results.windows.converged.all()


# --- a tour of the API: each part a Python participant of tests/test_precice.py written again in a compiled language
def tour_parts() -> dict[str, tuple[str, str, str, str, str | None]]:
    """part -> (configuration, the tour's participant, the partner's name, the partner's program, the Python
    participant the tour's part repeats, or None)."""
    from tests import test_precice as p
    field = p.FIELD_CONFIG.replace("MAPPING", "linear-cell-interpolation")
    volume = field.replace('dimensions="2"', 'dimensions="3"')
    target_3d = p.FIELD_TARGET.replace("[[0.1, 0.1], [0.55, 0.4], [0.9, 0.95], [1.2, 0.45]]",
                                       "[[0.1, 0.2, 0.3], [0.5, 0.5, 0.5], [0.9, 0.1, 0.7], [0.3, 0.8, 0.2]]")
    partner = p.PARTNER.replace("    t += dt", "    t = t if participant.requires_reading_checkpoint() else t + dt")
    return {"subcycling": (p.SUBCYCLING_CONFIG, "A", "B", partner, p.SUBCYCLING),     # B repeats its window's time
            "direct": (p.DIRECT_CONFIG, "Accessor", "Provider", p.DIRECT_PROVIDER, p.DIRECT_ACCESSOR),
            "jit": (p.JIT_CONFIG, "B", "A", p.JIT_PROVIDER, p.JIT_PARTICLES),
            "gradient": (p.GRADIENT_CONFIG, "A", "B", p.GRADIENT_READER, p.GRADIENT_WRITER),
            "quads": (field, "Source", "Target", p.FIELD_TARGET, p.FIELD_SOURCE.replace("CONNECT", p.QUADS)),
            "triangles": (field, "Source", "Target", p.FIELD_TARGET, None),
            "edges": (p.FIELD_CONFIG.replace("MAPPING", "nearest-projection"), "Source", "Target", p.FIELD_TARGET,
                      p.FIELD_SOURCE.replace("CONNECT", p.EDGES)),
            "tetrahedra": (volume, "Source", "Target", target_3d, None)}


def tour_case(folder: Path, part: str, tour: str | None) -> Path:
    """The part's case: the partner in Python, the tour's participant compiled (``tour``: its executable) or the
    Python participant it repeats (None); returns the run's folder."""
    from tests.test_precice import write_case
    config, name, partner, partner_program, python = tour_parts()[part]
    case_file = write_case(folder, {partner: partner_program, **({name: python} if tour is None else {})}, config)
    if tour is not None:
        (folder / name).mkdir(exist_ok=True)
        case_file.write_text(case_file.read_text() + f'[participants.{name}]\ncommand = "{tour} ../config.xml {part} '
                                                     f'{name}"\ncwd = "{name}"\n')
    from cosim.scene import load_scene
    from coupler.run import run_scene
    run_scene(load_scene(case_file), folder / "out", progress=False)
    return folder


@pytest.fixture(scope="module")
def python_tours(tmp_path_factory) -> dict[str, Path]:
    """Each part's run with the Python participant it repeats (where tests/test_precice.py has one)."""
    return {part: tour_case(tmp_path_factory.mktemp(f"python-{part}"), part, None)
            for part, spec in tour_parts().items() if spec[4] is not None}


def same_calls(a: Path, b: Path) -> None:
    """Two runs' windows, exchanged fields, residuals and every recorded call, bit for bit."""
    from cosim.results import RunResults
    with RunResults(a) as one, RunResults(b) as other:
        assert np.array_equal(one.windows.iterations, other.windows.iterations)
        assert all(np.array_equal(one.fields()[k], other.fields()[k]) for k in one.fields())
        assert all(np.array_equal(x, y) for x, y in zip(one.residuals(), other.residuals()))
        assert one.recorded() == other.recorded()
        for name in one.recorded():
            x, y = one.calls(name), other.calls(name)
            assert np.array_equal(x.window, y.window) and np.array_equal(x.iteration, y.iteration)
            for kind in ("inputs", "outputs"):
                assert all(np.array_equal(getattr(x, kind)[k], getattr(y, kind)[k]) for k in getattr(x, kind))


def seen_lines(folder: Path) -> list[list[float]]:
    return [[float(v) for v in line.split()] for line in (folder / "seen.txt").read_text().splitlines()]


@pytest.mark.parametrize("language", ["cpp", "c", "fortran"])
def test_a_tour_of_the_api_in_each_language_gives_the_python_participants_runs(served, python_tours, tmp_path,
                                                                               language):
    """Every call of the language's API, in eight parts, each a Python participant written again, against the same
    Python partner: what the compiled participant reads and what its partner reads are the Python run's, bit for
    bit (the Python parts' values are preCICE 3.4.1's in tests/test_precice.py); the parts no Python participant
    has are checked against the exact field (linear in the cells)."""
    from cosim.results import RunResults
    tour = program_build("tour", language, tmp_path, served)
    for part, (_, name, partner, _, python) in tour_parts().items():
        folder = tour_case(tmp_path / part, part, str(tour))
        assert "3.4.1" in (folder / "out" / "logs" / f"{name}.log").read_text()        # getVersionInformation
        if python is not None:
            reference = python_tours[part]
            same_calls(reference / "out", folder / "out")
            for seen in ("seen.json", "reads.json"):
                if (reference / partner / seen).exists():
                    assert json.loads((folder / partner / seen).read_text()) == \
                        json.loads((reference / partner / seen).read_text()), (part, seen)
        if part == "subcycling":
            assert seen_lines(folder / name) == json.loads((python_tours[part] / name / "seen.json").read_text())
        elif part == "direct":
            ids, coordinates = seen_lines(folder / name)
            assert ids == [3, 4, 5, 6, 7] and coordinates == np.column_stack([np.linspace(0.0, 1.0, 11)[3:8],
                                                                              np.zeros(5)]).ravel().tolist()
        elif part == "jit":
            assert seen_lines(folder / name) == json.loads((python_tours[part] / name / "reads.json").read_text())
        elif part == "gradient":
            assert seen_lines(folder / name) == [[1.0, 1.0]]
        elif part in ("triangles", "tetrahedra"):
            seen = np.array(json.loads((folder / partner / "seen.json").read_text()))
            if part == "triangles":     # the quads' values: linear in y between the rows, whatever the diagonal
                expected = np.array(json.loads((python_tours["quads"] / partner / "seen.json").read_text()))
                np.testing.assert_allclose(seen, expected, rtol=0, atol=1e-12)
            else:
                points = np.array([[0.1, 0.2, 0.3], [0.5, 0.5, 0.5], [0.9, 0.1, 0.7], [0.3, 0.8, 0.2]])
                for window, values in enumerate(seen, start=1):
                    np.testing.assert_allclose(values, window + 2 * points[:, 0] + 3 * points[:, 1] - points[:, 2],
                                               rtol=0, atol=1e-12)
        with RunResults(folder / "out") as results:
            assert results.windows.converged.all()
    assert children_of(os.getpid()) == []


def test_the_tours_call_every_function_of_the_three_apis():
    """Every method of precice::Participant, every precicec_ function and every precicef_ subroutine the headers
    declare is called in the tours (the Fortran names without gfortran's underscore), and both constructors."""
    import re
    include = SOURCE / "include" / "precice"
    methods = set(re.findall(r"\b(?:void|bool|int|double|VertexID)\s+(\w+)\(",
                             (include / "Participant.hpp").read_text())) | {"getVersionInformation"}
    c_functions = set(re.findall(r"\b(precicec_\w+)\(", (include / "preciceC.h").read_text()))
    fortran = {name.rstrip("_") for name in re.findall(r"\b(precicef_\w+)\(", (include / "preciceFortran.hpp")
                                                                                  .read_text())}
    assert len(methods) == 35 and len(c_functions) == 37 and len(fortran) == 43
    assert "Participant>(argv[3], argv[1], 0, 1, &communicator)" in (DATA / "tour.cpp").read_text()   # both constructors
    for names, source in ((methods, "tour.cpp"), (c_functions, "tour.c"), (fortran, "tour.f90")):
        text = (DATA / source).read_text()
        assert sorted(n for n in names if not re.search(rf"\b{n}\b", text)) == [], source


@pytest.mark.parametrize("language, call", [("cpp", "Participant::resetMesh"), ("c", "precicec_resetMesh"),
                                            ("fortran", "precicef_reset_mesh")])
def test_remeshing_is_refused_in_one_line_naming_the_call(served, tmp_path, language, call):
    from tests.test_precice import PARTNER, SUBCYCLING_CONFIG, write_case
    tour = program_build("tour", language, tmp_path, served)
    case_file = write_case(tmp_path, {"B": PARTNER}, SUBCYCLING_CONFIG)
    (tmp_path / "A").mkdir()
    case_file.write_text(case_file.read_text() + f'[participants.A]\ncommand = "{tour} ../config.xml reset A"\n'
                                                 'cwd = "A"\n')
    from cosim.scene import load_scene
    from coupler.run import run_scene
    with pytest.raises(CosimError, match=rf"component 'A' .*: {call}: remeshing is not supported by cosim: mesh "
                                         r"'A-Mesh' keeps the vertices it had at initialize for the whole run$"):
        run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    assert children_of(os.getpid()) == []


def test_compiled_participants_couple_to_each_other_as_the_python_pair_does(served, python_tours, tmp_path):
    """The subcycling pair with both sides compiled, in three pairings of the languages: the same run, bit for bit,
    whichever languages (the same libm's sine on both sides), and the Python pair's to round-off (NumPy's sine)."""
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from tests.test_precice import SUBCYCLING_CONFIG
    languages = ["cpp", "c", "fortran"] if shutil.which("gfortran") else ["cpp", "c"]
    tours = {language: program_build("tour", language, tmp_path / language, served) for language in languages}
    runs = []
    for first, second in zip(languages, languages[1:] + languages[:1]):
        folder = tmp_path / f"{first}-{second}"
        for name in ("A", "B"):
            (folder / name).mkdir(parents=True)
        (folder / "config.xml").write_text(SUBCYCLING_CONFIG)
        (folder / "case.toml").write_text(
            f'[precice]\nconfig = "config.xml"\n[participants.A]\ncommand = "{tours[first]} ../config.xml subcycling '
            f'A"\ncwd = "A"\n[participants.B]\ncommand = "{tours[second]} ../config.xml partner B"\ncwd = "B"\n')
        run_scene(load_scene(folder / "case.toml"), folder / "out", progress=False)
        runs.append(folder)
    for other in runs[1:]:
        same_calls(runs[0] / "out", other / "out")
        assert seen_lines(other / "A") == seen_lines(runs[0] / "A")
    with RunResults(runs[0] / "out") as compiled, RunResults(python_tours["subcycling"] / "out") as python:
        assert np.array_equal(compiled.windows.iterations, python.windows.iterations)
        assert compiled.windows.converged.all()
        for name, values in python.fields().items():
            np.testing.assert_allclose(compiled.fields()[name], values, rtol=1e-13, atol=1e-15)
    assert children_of(os.getpid()) == []


BROKEN_CONFIG = """<?xml version="1.0"?>
<precice-configuration>
  <data:scalar name="X"/>
  <mesh name="A-Mesh" dimensions="2"><use-data name="X"/></mesh>
  <participant name="A"><provide-mesh name="A-Mesh"/><write-data name="X" mesh="A-Mesh"/></participant>
  <coupling-scheme:serial-explicit>
    <participants first="A" second="B"/><max-time-windows value="2"/><time-window-size value="1.0"/>
    <exchange data="X" mesh="A-Mesh" from="A" to="B"/>
  </coupling-scheme:serial-explicit>
</precice-configuration>
"""


@pytest.mark.parametrize("language", ["python", "c"])
def test_a_participant_started_by_hand_whose_coupler_stops_at_start_up_says_why_at_once(prefix, tmp_path, language):
    """The first participant started by hand starts the coupler; the configuration names a participant it does not
    define, so the coupler stops at once: the participant ends with the coupler's line, exit code 2, without
    waiting out the 60 s it gives a coupler to answer."""
    import sys
    (tmp_path / "config.xml").write_text(BROKEN_CONFIG)
    (tmp_path / "A").mkdir()
    environment = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
                   "PYTHONPATH": str(ROOT / "precice_compat" / "participant"), "LD_LIBRARY_PATH": str(prefix / "lib")}
    environment.pop("COSIM_PARTICIPANT_ENDPOINT", None)
    if language == "python":
        (tmp_path / "A" / "a.py").write_text('import precice\np = precice.Participant("A", "../config.xml", 0, 1)\n')
        command = [sys.executable, "a.py"]
    else:
        command = [str(pkg_config_build(DATA / "tour.c", tmp_path / "tour", prefix)), "../config.xml", "reset", "A"]
    done = subprocess.run(command, cwd=tmp_path / "A", env=environment, capture_output=True, text=True, timeout=50)
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 2 and last.startswith("precice: error: ")
    assert last.endswith("before it listened: cosim run: error: " + str(tmp_path / "config.xml") + ", line 6: "
                         "<coupling-scheme:serial-explicit>: participant 'B' is not defined (participants: A)"), last
    assert children_of(os.getpid()) == []
