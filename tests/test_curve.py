"""Remote components behind CURVE: key directories, a served tube solid over an authenticated, encrypted
connection giving the local run's results, and clients the server does not know refused at once."""

from __future__ import annotations

import shutil
import subprocess
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from cosim.cli import main
from cosim.results import RunResults
from cosim.scene import load_scene
from coupler.run import run_scene
from tests.conftest import TUBE_SCENE, served_by_hand, wait_for

SHORT = ["time.end=0.5"]


@pytest.fixture(scope="module")
def keys(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("curve") / "keys"
    assert main(["keys", str(folder)]) == 0
    return folder


def served(entry: str, bind: str, curve: Path, prefix: tuple[str, ...] = ()):
    """``cosim serve ENTRY --bind BIND --curve DIR`` by hand (tests.conftest.served_by_hand)."""
    return served_by_hand(entry, bind, curve, prefix)


def remote(endpoint: str, curve: Path) -> list[str]:
    return ["components.solid.entry=''", f"components.solid.address='{endpoint}'", f"components.solid.curve='{curve}'",
            "components.solid.startup_timeout=10.0"]


def test_keys_are_made_once_and_never_overwritten(keys, capsys):
    assert sorted(p.name for p in keys.iterdir()) == ["client.key", "client.key_secret", "clients", "server.key",
                                                      "server.key_secret"]
    assert [p.name for p in (keys / "clients").iterdir()] == ["client.key"]
    assert (keys / "server.key_secret").stat().st_mode & 0o077 == 0            # secrets readable by their owner only
    assert main(["keys", str(keys)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "keys are never overwritten" in err and "server.key" in err


def test_a_curve_served_solid_couples_the_tube_to_the_local_run_s_results(keys, tmp_path):
    run_scene(load_scene(TUBE_SCENE, SHORT), tmp_path / "local", progress=False)
    with served("solid_component.tube:TubeSolid", "tcp://127.0.0.1:*", keys) as handshake:
        assert handshake["curve"] is True
        run_scene(load_scene(TUBE_SCENE, [*SHORT, *remote(handshake["endpoint"], keys)]), tmp_path / "remote",
                  progress=False)
    with RunResults(tmp_path / "local" / "results.h5") as local, RunResults(tmp_path / "remote" / "results.h5") as far:
        np.testing.assert_array_equal(far.windows.iterations, local.windows.iterations)
        for name, values in local.fields().items():
            assert far.fields()[name].tobytes() == values.tobytes(), name
        solid = far.component("solid").attributes
        assert solid["host"] == handshake["endpoint"] and bool(solid["curve"]) is True
        assert bool(local.component("solid").attributes["curve"]) is False


def test_a_client_the_server_does_not_list_is_refused_at_once_naming_the_component(keys, tmp_path, capsys):
    stranger = tmp_path / "stranger"
    assert main(["keys", str(stranger)]) == 0
    shutil.copy(keys / "server.key", stranger / "server.key.own")
    (stranger / "server.key").unlink()
    (stranger / "server.key.own").rename(stranger / "server.key")       # the right server, an unknown client key
    with served("solid_component.tube:TubeSolid", "tcp://127.0.0.1:*", keys) as handshake:
        started = time.monotonic()
        code = main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "run"), "--quiet",
                     *[arg for item in [*SHORT, *remote(handshake["endpoint"], stranger)] for arg in ("--set", item)]])
        elapsed = time.monotonic() - started
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err, err
    assert "component 'solid'" in err and "refused this client's CURVE key" in err, err
    assert elapsed < 10.0      # the handshake's failure, not the 10 s start-up timeout


@pytest.mark.parametrize("client, message", [
    ("wrong-server-key", "the CURVE handshake with {endpoint} failed: '{keys}/server.key' is not the server's public key"),
    ("plaintext", "the handshake with {endpoint} failed: the server speaks CURVE (`cosim serve --curve`)"),
])
def test_a_failed_handshake_is_named_within_seconds_not_at_the_start_up_timeout(keys, tmp_path, capsys, client,
                                                                                message):
    other = tmp_path / "other"
    assert main(["keys", str(other)]) == 0
    mine = tmp_path / "mine"
    mine.mkdir()
    shutil.copy(keys / "client.key_secret", mine / "client.key_secret")
    shutil.copy(other / "server.key", mine / "server.key")              # another server's public key
    with served("solid_component.tube:TubeSolid", "tcp://127.0.0.1:*", keys) as handshake:
        endpoint = handshake["endpoint"]
        settings = [*SHORT, "components.solid.entry=''", f"components.solid.address='{endpoint}'"]
        if client == "wrong-server-key":
            settings.append(f"components.solid.curve='{mine}'")
        started = time.monotonic()
        code = main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "run"), "--quiet",
                     *[arg for item in settings for arg in ("--set", item)]])
        elapsed = time.monotonic() - started
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err, err
    assert message.format(endpoint=endpoint, keys=mine) in err, err
    assert elapsed < 10.0          # the start-up timeout is 60 s


def test_without_curve_keys_a_scene_or_a_bind_beyond_loopback_is_refused(keys, tmp_path, capsys):
    assert main(["serve", "solid_component.tube:TubeSolid", "--bind", "tcp://0.0.0.0:5555"]) == 2
    assert "refusing to bind 'tcp://0.0.0.0:5555' without CURVE" in capsys.readouterr().err
    code = main(["check", str(TUBE_SCENE), "--set", "components.solid.entry=''", "--set",
                 "components.solid.address='tcp://127.0.0.1:5555'", "--set", f"components.solid.curve='{tmp_path}'"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "'components.solid.curve'" in err and "client.key_secret" in err, err
    code = main(["check", str(TUBE_SCENE), "--set", f"components.solid.curve='{keys}'"])
    assert code == 2 and "set 'components.solid.address' too" in capsys.readouterr().err


@contextmanager
def namespace(name: str, host: str, peer: str):
    """A network namespace holding ``peer``'s end of a veth pair whose other end has ``host`` here."""
    commands = [["ip", "netns", "add", name], ["ip", "link", "add", f"{name}0", "type", "veth", "peer", "name",
                                                f"{name}1"],
                ["ip", "link", "set", f"{name}1", "netns", name], ["ip", "addr", "add", f"{host}/24", "dev", f"{name}0"],
                ["ip", "link", "set", f"{name}0", "up"],
                ["ip", "netns", "exec", name, "ip", "addr", "add", f"{peer}/24", "dev", f"{name}1"],
                ["ip", "netns", "exec", name, "ip", "link", "set", f"{name}1", "up"],
                ["ip", "netns", "exec", name, "ip", "link", "set", "lo", "up"]]
    try:
        for command in commands:
            if subprocess.run(command, capture_output=True).returncode != 0:
                pytest.skip(f"cannot make a network namespace here ({' '.join(command)} failed)")
        yield
    finally:
        subprocess.run(["ip", "netns", "del", name], capture_output=True)
        subprocess.run(["ip", "link", "del", f"{name}0"], capture_output=True)


@pytest.mark.skipif(shutil.which("ip") is None, reason="needs iproute2 and root for a network namespace")
def test_a_solid_served_in_another_network_namespace_couples_over_its_own_address(keys, tmp_path):
    run_scene(load_scene(TUBE_SCENE, SHORT), tmp_path / "local", progress=False)
    with namespace("cosimt", "10.231.7.1", "10.231.7.2"):
        prefix = ("ip", "netns", "exec", "cosimt")
        with served("solid_component.tube:TubeSolid", "tcp://10.231.7.2:*", keys, prefix) as handshake:
            assert handshake["endpoint"].startswith("tcp://10.231.7.2:")
            run_scene(load_scene(TUBE_SCENE, [*SHORT, *remote(handshake["endpoint"], keys)]), tmp_path / "far",
                      progress=False)
    with RunResults(tmp_path / "local" / "results.h5") as local, RunResults(tmp_path / "far" / "results.h5") as far:
        for name, values in local.fields().items():
            assert far.fields()[name].tobytes() == values.tobytes(), name


def test_a_remote_component_that_disappears_stops_the_run_within_its_timeout_naming_it(keys, tmp_path, capsys):
    """The launcher's guarantees for a component it did not launch: no hang, a named one-line failure."""
    with served("solid_component.tube:TubeSolid", "tcp://127.0.0.1:*", keys) as handshake:
        out = tmp_path / "run"
        overrides = ["time.end=200.0", *remote(handshake["endpoint"], keys), "components.solid.timeout=2.0"]
        import threading

        from cosim.rundir import read_status
        result: dict[str, int] = {}
        runner = threading.Thread(target=lambda: result.setdefault("code", main(
            ["run", str(TUBE_SCENE), "--out", str(out), "--quiet", *[a for o in overrides for a in ("--set", o)]])))
        runner.start()
        wait_for(lambda: int(read_status(out).get("windows_completed", 0)) >= 20, "20 windows of the run")
        subprocess.run(["kill", "-9", str(handshake["pid"])], check=True)       # the remote host goes away
        gone = time.monotonic()
        runner.join(timeout=30)
        assert not runner.is_alive()
        elapsed = time.monotonic() - gone
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert result["code"] == 2 and "component 'solid'" in err and "no reply to 'step' within 2 s" in err, err
    assert elapsed < 10.0
    with RunResults(out / "results.h5") as run:
        assert len(run.windows.iterations) >= 20            # every window before is kept


def bad_keys(keys: Path, tmp_path: Path) -> Path:
    """A copy of the key directory, to damage."""
    copy = tmp_path / "bad"
    shutil.copytree(keys, copy)
    return copy


def test_a_malformed_or_world_readable_key_is_named_by_check_and_by_serve(keys, tmp_path, capsys):
    bad = bad_keys(keys, tmp_path)
    text = (bad / "server.key").read_text()
    (bad / "server.key").write_text("\n".join('    public-key = "short"' if "public-key" in line else line
                                              for line in text.splitlines()) + "\n")
    scene = ["check", str(TUBE_SCENE), "--static", "--set", "components.solid.entry=''", "--set",
             "components.solid.address='tcp://127.0.0.1:5555'", "--set", f"components.solid.curve='{bad}'"]
    assert main(scene) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"CURVE key '{bad}/server.key': its public-key is not a key (5 characters" in err, err
    shutil.copy(keys / "server.key", bad / "server.key")
    (bad / "client.key_secret").chmod(0o644)
    assert main(scene) == 2
    err = capsys.readouterr().err.strip()
    assert f"CURVE secret key '{bad}/client.key_secret' is readable by others (mode 644)" in err, err
    (bad / "client.key_secret").chmod(0o600)
    text = (bad / "server.key_secret").read_text()
    (bad / "server.key_secret").write_text("\n".join('    secret-key = "abc"' if "secret-key" in line else line
                                                     for line in text.splitlines()) + "\n")
    assert main(["serve", "solid_component.tube:TubeSolid", "--curve", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"CURVE key '{bad}/server.key_secret': its secret-key is not a key" in err, err


def test_keys_are_written_unreadable_to_others_from_the_start(tmp_path, monkeypatch):
    import zmq.auth
    modes = {}
    create = zmq.auth.create_certificates

    def observed(directory, name, *args, **kwargs):
        public, secret = create(directory, name, *args, **kwargs)
        modes[Path(secret).name] = Path(secret).stat().st_mode & 0o777
        return public, secret
    monkeypatch.setattr(zmq.auth, "create_certificates", observed)
    assert main(["keys", str(tmp_path / "keys")]) == 0
    assert modes == {"server.key_secret": 0o600, "client.key_secret": 0o600}
    assert (tmp_path / "keys" / "server.key").stat().st_mode & 0o777 == 0o644
