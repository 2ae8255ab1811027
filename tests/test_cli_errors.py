"""Bad input on the command line: one line naming what is wrong, exit code 2, no traceback."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from cosim.cli import main
from tests.conftest import ROOT, TUBE_SCENE


def one_line_error(capsys, argv: list[str]) -> str:
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert "\n" not in err and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("override, message", [
    ("components.solid=5", r"'components.solid' must be a table, got int 5"),
    ("coupling.convergence.x=1", r"'x' is not an index of 'coupling.convergence' \(a list of 2 entries: 0 to 1\)"),
    ("coupling.convergence.9=1", r"'9' is not an index of 'coupling.convergence'"),
    ("time.dt=nan", r"'time.dt' must be a finite number, got nan"),
    ("time.end=inf", r"'time.end' must be a finite number, got inf"),
    ("time.dt=1e-300", r"'time.dt' = 1e-300 makes 1e\+300 windows .*at most 10,000,000"),
    ("coupling.acceleration.initial_relaxation=-1", r"'coupling.acceleration.initial_relaxation' is -1.0; allowed: \(0, 1\]"),
    ("coupling.acceleration.max_used_iterations=-3", r"'coupling.acceleration.max_used_iterations' is -3; allowed: an integer >= 1"),
    ("coupling.acceleration.reused_time_windows=-1", r"reused_time_windows' is -1; allowed: an integer >= 0"),
    ("components.solid.timeout=0", r"'components.solid.timeout' is 0.0; allowed: a number > 0"),
    ("coupling.acceleration.filter_limit=-1", r"'coupling.acceleration.filter_limit' is -1.0; allowed: \(0, 1\)"),
    ("coupling.convergence.0.limit=0", r"'coupling.convergence.0.limit' is 0.0; allowed: a number > 0"),
    ('coupling.acceleration.data=["pressure"]', r"'coupling.acceleration.data.0' is 'pressure', but serial-implicit "
                                                r"accelerates the data the second participant 'solid' sends: section"),
    ('coupling.acceleration.data=["section", "section"]', r"'coupling.acceleration.data.1' repeats 'section'"),
    ('coupling.acceleration.data=["stress"]', r"'coupling.acceleration.data.0' is 'stress', not exchanged data"),
    ("coupling=5", r"'coupling' must be a table"),
    ("components.solid.sections=[1]", r"'components.solid.sections.0' must be a string, got 1"),
    # component parameters are checked before any process starts, against the schema the component declares
    ("tube.a0=-1", r"error: 'tube.a0' is -1.0; allowed: a number > 0 in .*tube_fom.toml$"),
    ("tube.cells=10000000", r"error: 'tube.cells' is 10000000; allowed: \[2, 1,000,000\] \(an integer\)"),
    ("inlet.hh=4", r"unknown key 'inlet.hh' in .*tube_fom.toml; did you mean 'inlet.h'\?"),
    ("components.solid.parameters.E_smal=1e6", r"unknown key 'components.solid.parameters.E_smal' in .*; did you "
                                               r"mean 'components.solid.parameters.E_small'\?"),
    ("components.solid.parameters.E_small=-1", r"'components.solid.parameters.E_small' is -1.0; allowed: a number > 0"),
    ('components.fluid.address="nonsense"', r"'components.fluid.address' is 'nonsense'; allowed: tcp://HOST:PORT"),
    ("components.fluid.address='tcp://127.0.0.1:0'", r"'components.fluid.address' is 'tcp://127.0.0.1:0'"),
    ("output.plot_index=1000", r"'output.plot_index' is 1000, but 'pressure' has 101 values \(0 to 100\)"),
    # a backend's table is checked against its class's parameter_schema (the ROM's settings live in the ROM)
    ("components.solid.rom.arithmetic=exact", r"'components.solid.rom.arithmetic' is 'exact'; allowed: reproducible, "
                                              r"compiled, fast"),
    ("components.solid.rom.range_margn=0.1", r"unknown key 'components.solid.rom.range_margn' .*did you mean "
                                             r"'components.solid.rom.range_margin'\?"),
    ("components.solid.fmu.state=maybe", r"'components.solid.fmu.state' is 'maybe'; allowed: auto, rollback, stateless"),
])
def test_bad_scene_values_are_one_line_errors(capsys, tmp_path, override, message):
    extra = ["--set", 'components.fluid.entry=""'] if override.startswith("components.fluid.address") else []
    err = one_line_error(capsys, ["run", str(TUBE_SCENE), "--out", str(tmp_path / "run"), "--quiet",
                                  "--set", "time.end=1", *extra, "--set", override])
    assert err.startswith("cosim run: error: ")
    assert __import__("re").search(message, err), err
    if "plot_index" not in override:    # a field's size is known once its component describes it
        assert not (tmp_path / "run" / "logs").exists()     # refused before any component process started


@pytest.mark.parametrize("model, message", [
    ("", r"components.solid.backend is 'rom' but 'components.solid.rom.model' is not set"),
    # (a campaign checks its ROM-FOM runs before it trains their models: the ROM itself finds the file missing)
    ("missing.npz", r"component 'solid_rom' in start-up: 'instantiate' failed: model file 'missing.npz' does not exist"),
])
def test_a_selected_backend_needs_its_file(capsys, tmp_path, model, message):
    err = one_line_error(capsys, ["run", str(TUBE_SCENE), "--out", str(tmp_path / "run"), "--quiet", "--set", "time.end=0.2",
                                  "--set", "components.solid.backend=rom", "--set", f"components.solid.rom.model='{model}'"])
    assert __import__("re").search(message, err), err


def test_scene_files_that_are_no_scenes(capsys, tmp_path):
    binary = tmp_path / "latin1.toml"
    binary.write_bytes(TUBE_SCENE.read_bytes() + b'name = "caf\xe9"\n')
    err = one_line_error(capsys, ["run", str(binary), "--out", str(tmp_path / "a")])
    assert err.endswith(f"{binary}: not UTF-8 text (byte 0xe9 on line {TUBE_SCENE.read_text().count(chr(10)) + 1})")
    for depth in (40, 5000):     # nested deeper than a scene, and deeper than the parser's recursion
        deep = tmp_path / f"deep{depth}.toml"
        deep.write_text("x = " + "[" * depth + "]" * depth + "\n")
        err = one_line_error(capsys, ["run", str(deep), "--out", str(tmp_path / "b")])
        assert err.endswith(f"{deep}: tables or arrays nest more than 32 deep")
    err = one_line_error(capsys, ["run", str(TUBE_SCENE), "--out", str(tmp_path / "c"),
                                  "--set", "time.end=" + "[" * 5000 + "]" * 5000])
    assert "the value nests arrays or tables too deeply" in err
    assert not any((tmp_path / name).exists() for name in "abc")


@pytest.mark.parametrize("out", ["", "   ", "a-file", "a-file/run"])
def test_an_output_directory_that_cannot_be_one(capsys, tmp_path, monkeypatch, out):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a-file").write_text("not a directory")
    err = one_line_error(capsys, ["run", str(TUBE_SCENE), "--out", out, "--quiet", "--set", "time.end=0.2"])
    expected = "--out is empty" if not out.strip() else \
        f"cannot use '{out}' as the run's directory: " + ("File exists" if out == "a-file" else "Not a directory")
    assert expected in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]     # nothing written into the working folder


def test_serve_refuses_what_is_not_a_component_class(capsys):
    err = one_line_error(capsys, ["serve", "builtins:dict"])
    assert err == ("cosim serve: error: entry 'builtins:dict': 'dict' is not a component class (a subclass of "
                   "cosim.component.Component)")


def test_export_fmu_of_a_text_file(capsys, tmp_path):
    text = tmp_path / "model.npz"
    text.write_text("not a model")
    err = one_line_error(capsys, ["export-fmu", str(text), "--out", str(tmp_path / "rom.fmu")])
    assert "is not a valid .npz (not a zip archive)" in err


def test_train_of_a_non_hdf5_file(capsys, tmp_path):
    text = tmp_path / "results.h5"
    text.write_text("not results")
    err = one_line_error(capsys, ["train", str(text), "--out", str(tmp_path / "m.npz")])
    assert "is not an HDF5 results file" in err


def test_serve_refuses_an_unknown_transport(capsys):
    err = one_line_error(capsys, ["serve", "solid_component.tube:TubeSolid", "--bind", "TCP://127.0.0.1:5555"])
    assert "bind address 'TCP://127.0.0.1:5555' is not of the form tcp://HOST:PORT" in err


def test_serve_on_a_port_in_use(capsys):
    import zmq
    socket = zmq.Context.instance().socket(zmq.ROUTER)
    port = socket.bind_to_random_port("tcp://127.0.0.1")
    try:
        done = subprocess.run([sys.executable, "-m", "cosim", "serve", "solid_component.tube:TubeSolid",
                               "--bind", f"tcp://127.0.0.1:{port}"], cwd=ROOT, capture_output=True, text=True,
                              timeout=60)
    finally:
        socket.close(linger=0)
    assert done.returncode == 2
    assert done.stderr.strip().startswith(f"cosim serve: error: cannot bind 'tcp://127.0.0.1:{port}': "
                                          "Address already in use")
    assert "\n" not in done.stderr.strip()


def test_train_and_report_of_a_truncated_results_file(capsys, tmp_path):
    from cosim.scene import load_scene
    from coupler.run import run_scene
    run_scene(load_scene(TUBE_SCENE, ["time.end=0.5", "components.solid.record=true"]), tmp_path / "run",
              progress=False)
    whole = (tmp_path / "run" / "results.h5").read_bytes()
    (tmp_path / "cut").mkdir()
    cut = tmp_path / "cut" / "results.h5"
    cut.write_bytes(whole[: len(whole) // 2])
    for argv in (["train", str(cut), "--out", str(tmp_path / "m.npz")],
                 ["report", f"{tmp_path / 'cut'}={tmp_path / 'run'}", "--out", str(tmp_path / "report")]):
        err = one_line_error(capsys, argv)
        assert f"cannot read '{cut}': it is truncated or damaged" in err
    assert not (tmp_path / "m.npz").exists()


def test_version_and_every_subcommand_s_help_has_a_description_an_example_and_every_option_explained(capsys):
    from importlib.metadata import version

    from cosim.cli import commands, parser
    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out.strip() == f"cosim {version('cosim-rom-fsi')}"
    sub = next(a for a in parser()._actions if a.dest == "command")
    for name in commands():
        command = sub.choices[name]
        assert command.description and command.epilog.startswith("example:\n  cosim "), name
        for action in command._actions:
            assert action.help, f"cosim {name} {action.option_strings or action.dest} has no help"


def test_check_validates_without_running_and_prints_the_resolved_scene(capsys, tmp_path):
    import json
    assert main(["check", str(TUBE_SCENE), "--set", "time.end=2"]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""                                  # the resolved scene only on request
    lines = captured.err.splitlines()
    assert lines[0] == (f"{TUBE_SCENE}: valid (every component started and instantiated); 20 windows, "
                        "components fluid, solid")                 # the verdict first, then the notes
    assert "  solid: input pressure (101,), output section (101,)" in lines[1:]
    assert main(["check", str(TUBE_SCENE), "--set", "time.end=2", "--print"]) == 0
    captured = capsys.readouterr()
    resolved = json.loads(captured.out)
    assert resolved["time"]["end"] == 2 and resolved["coupling"]["acceleration"]["type"] == "iqn-ils"
    assert resolved["coupling"]["acceleration"]["on_map_change"] == "drop-span"   # a default the scene omits
    assert captured.err.splitlines()[0].endswith("valid (every component started and instantiated); 20 windows, "
                                                 "components fluid, solid")
    assert main(["check", str(TUBE_SCENE), "--set", "components.solid.parameters.E_smal=1"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "cosim check: error: unknown key 'components.solid.parameters.E_smal' in " + str(TUBE_SCENE)
        + "; did you mean 'components.solid.parameters.E_small'?"]


def test_check_knows_the_variables_components_declare(capsys):
    """A variable misspelt alike in the exchange, the measure and the acceleration passes every static check; the
    instantiated components name the ones they have."""
    sektion = ["--set", 'exchange.1.data="sektion"', "--set", 'coupling.convergence.1.data="sektion"',
               "--set", 'coupling.acceleration.data=["sektion"]']
    err = one_line_error(capsys, ["check", str(TUBE_SCENE), *sektion])
    assert err.endswith("'exchange.1.data' is 'sektion', but component 'solid' has no output 'sektion' "
                        "(outputs: section)"), err
    assert main(["check", str(TUBE_SCENE), "--static", *sektion]) == 0     # the static checks alone pass it


def test_check_tries_an_address_with_a_short_deadline_and_says_what_to_check(capsys):
    import socket
    import time
    with socket.socket() as free:
        free.bind(("127.0.0.1", 0))
        port = free.getsockname()[1]
    started = time.monotonic()
    err = one_line_error(capsys, ["check", str(TUBE_SCENE), "--set", "components.solid.entry=''",
                                  "--set", f"components.solid.address='tcp://127.0.0.1:{port}'"])
    assert time.monotonic() - started < 30.0
    assert f"no reply from tcp://127.0.0.1:{port} within 5 s: check that `cosim serve` runs there" in err, err
    assert "whether it serves with --curve (then set components.solid.curve)" in err, err


def test_check_refuses_what_a_run_would_refuse_before_its_first_window(capsys, tmp_path):
    err = one_line_error(capsys, ["check", str(TUBE_SCENE), "--set", "components.solid.entry=no_such_module:Solid"])
    assert err.endswith("component 'solid': did not start: entry 'no_such_module:Solid': cannot import module "
                        "'no_such_module': No module named 'no_such_module' (a module of your own goes next to the "
                        "scene file, or on PYTHONPATH)"), err
    table = tmp_path / "inlet.png"
    table.write_bytes(b"\x89PNG\r\n\x1a\n not a table")
    err = one_line_error(capsys, ["check", str(TUBE_SCENE), "--set", f"inlet.table={table}"])
    assert f"inlet.table: '{table}'" in err and "(its log" not in err, err
    for kind, key in (("rom", "model"), ("fmu", "path")):
        err = one_line_error(capsys, ["check", str(TUBE_SCENE), "--set", f"components.solid.backend={kind}",
                                      "--set", f"components.solid.{kind}.{key}={tmp_path}"])
        assert err.endswith(f"'components.solid.{kind}.{key}' names '{tmp_path}', which is a directory, not a file")


def test_special_files_named_as_inputs_are_refused_at_once(capsys, tmp_path):
    """A FIFO as a scene, a case or a preCICE configuration would block the read forever, /dev/zero would be read
    without end, and a FIFO or a damaged status.json made `cosim status` hang or crash: each is refused or read as
    no status, within the test's seconds."""
    import json
    import os
    import shutil
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    err = one_line_error(capsys, ["check", str(fifo)])
    assert err.endswith(f"cannot read scene '{fifo}': it is a FIFO, not a regular file"), err
    err = one_line_error(capsys, ["check", "/dev/zero"])
    assert "it is a device or socket, not a regular file" in err, err
    case = tmp_path / "case"
    shutil.copytree(ROOT / "examples" / "precice_tube", case, ignore=shutil.ignore_patterns("*.npz", "*.fmu"))
    (case / "precice-config.xml").unlink()
    os.mkfifo(case / "precice-config.xml")
    err = one_line_error(capsys, ["check", str(case / "case.toml")])
    assert "precice-config.xml': it is a FIFO, not a regular file" in err, err
    from cosim.rundir import read_status
    for damaged in ("[1, 2]", '"running"', "{", "[" * 5000 + "]" * 5000):
        (tmp_path / "status.json").write_text(damaged)
        assert read_status(tmp_path) == {}
    (tmp_path / "status.json").unlink()
    os.mkfifo(tmp_path / "status.json")
    assert read_status(tmp_path) == {}
    (tmp_path / "status.json").unlink()
    (tmp_path / "status.json").write_text(json.dumps({"state": "finished", "windows_completed": 3}))
    assert read_status(tmp_path)["windows_completed"] == 3
    (tmp_path / "status.json").write_text('{"state": "finished", "windows_completed": "x", "windows_total": 10, '
                                          '"wall_seconds": NaN, "measures": {"a": "b", "c": 1.5}, "error": 7}')
    assert read_status(tmp_path) == {"state": "finished", "windows_total": 10, "measures": {"c": 1.5}}
    assert main(["status", str(tmp_path)]) == 0          # the fields it can read, no traceback
    assert "finished, 0 of 10 windows" in capsys.readouterr().out
    (tmp_path / "status.json").write_text('{"state": "died", "windows_completed": 4, "windows_total": "x"}')
    assert main(["status", str(tmp_path)]) == 0          # what it lost is left out, not printed as None
    out = capsys.readouterr().out
    assert "died, 4 windows" in out and "its process is gone" in out and "None" not in out, out


@pytest.mark.parametrize(("path", "kind"), [("rom_configs/tube_rom.toml", "a ROM configuration, for cosim train"),
                                            ("rom_configs/mok_rom.toml", "a ROM configuration, for cosim train"),
                                            ("campaigns/double_flap_short.toml", "a campaign file, for cosim campaign")])
def test_a_rom_configuration_or_a_campaign_run_as_a_scene_is_told_what_it_is(capsys, path, kind):
    err = one_line_error(capsys, ["run", str(ROOT / path), "--out", "unused"])
    assert f"{ROOT / path}: this is {kind}" in err and "not a scene" in err


def test_the_commands_are_listed_in_the_order_of_a_users_work_and_run_names_every_input_kind(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    listed = re.search(r"\{([a-z,-]+)\}", capsys.readouterr().out).group(1).split(",")
    assert listed[:4] == ["check", "run", "status", "plot"] and listed[-2:] == ["serve", "keys"]
    assert listed.index("train") < listed.index("export-fmu") < listed.index("report") < listed.index("campaign")
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = "".join(capsys.readouterr().out.split())           # argparse wraps lines, at hyphens too
    for kind in ("a scene (TOML", "case file (case.toml) of a preCICE or Kratos case", "precice-config.xml",
                 "ProjectParametersCoSim.json"):
        assert "".join(kind.split()) in text, kind
