import msgpack
import numpy as np
import pytest

from cosim import protocol
from cosim.errors import ComponentError, ProtocolError
from cosim.server import ComponentServer
from solid_component.tube import TubeSolid


def test_float64_round_trip_is_bit_exact():
    rng = np.random.default_rng(0)
    special = np.array([np.nan, np.inf, -np.inf, -0.0, 5e-324, np.finfo(float).max, np.finfo(float).eps])
    arrays = {"random": rng.standard_normal(1001) * 10.0 ** rng.integers(-300, 300, 1001),
              "special": special, "matrix": rng.standard_normal((7, 3)), "empty": np.zeros(0)}
    header, decoded = protocol.decode(protocol.encode({"op": "step", "id": 3}, arrays))
    assert header["op"] == "step" and header["id"] == 3
    for name, value in arrays.items():
        assert decoded[name].dtype == np.float64
        assert decoded[name].shape == value.shape
        assert decoded[name].tobytes() == value.tobytes(), name


def test_other_dtypes_round_trip():
    arrays = {"i": np.arange(5, dtype=np.int32), "b": np.array([True, False]), "f": np.ones(3, np.float32)}
    _, decoded = protocol.decode(protocol.encode({"op": "ping"}, arrays))
    for name, value in arrays.items():
        np.testing.assert_array_equal(decoded[name], value)
        assert decoded[name].dtype == value.dtype


def test_non_contiguous_array_is_sent_in_c_order():
    a = np.arange(12.0).reshape(3, 4).T
    _, decoded = protocol.decode(protocol.encode({"op": "ping"}, {"a": a}))
    np.testing.assert_array_equal(decoded["a"], a)


def test_frame_length_must_match_declared_shape():
    frames = protocol.encode({"op": "step"}, {"x": np.zeros(101)})
    frames[1] = bytes(100 * 8)
    with pytest.raises(ProtocolError, match=r"array 'x': shape \(101,\) of float64 needs 808 bytes but its frame has 800"):
        protocol.decode(frames)


@pytest.mark.parametrize("mutate, message", [
    (lambda h: h.update(v=99), "protocol version 99"),
    (lambda h: h["arrays"][0].update(dtype="object"), "dtype 'object' is not allowed"),
    (lambda h: h["arrays"][0].update(shape=[-1]), "not a list of non-negative integers"),
    (lambda h: h["arrays"].append({"name": "y", "dtype": "float64", "shape": [1]}), "declares 2 arrays but 1"),
])
def test_malformed_headers_are_rejected(mutate, message):
    frames = protocol.encode({"op": "step"}, {"x": np.zeros(4)})
    header = msgpack.unpackb(frames[0])
    mutate(header)
    frames[0] = msgpack.packb(header)
    with pytest.raises(ProtocolError, match=message):
        protocol.decode(frames)


def test_garbage_and_oversize_messages_are_rejected():
    with pytest.raises(ProtocolError, match="not valid msgpack"):
        protocol.decode([b"\xc1\xc1\xc1"])
    with pytest.raises(ProtocolError, match="exceeds the limit"):
        protocol.decode(protocol.encode({"op": "ping"}, {"x": np.zeros(100)}), max_bytes=100)


def test_server_answers_malformed_requests_with_errors():
    component = TubeSolid()
    server = ComponentServer(component)
    reply, stop = server.handle([b"not msgpack at all"])
    header, _ = protocol.decode(reply)
    assert header["ok"] is False and "msgpack" in header["error"]["message"] and not stop
    reply, _ = server.handle(protocol.encode({"op": "format_disk", "id": 1}))
    header, _ = protocol.decode(reply)
    assert header["ok"] is False and "unknown op 'format_disk'" in header["error"]["message"]
    server.handle(protocol.encode({"op": "instantiate", "id": 2, "args": {"parameters": {}}}))
    reply, _ = server.handle(protocol.encode({"op": "step", "id": 3, "args": {"t": 0.0, "dt": 0.1}},
                                             {"pressure": np.zeros(100)}))
    header, _ = protocol.decode(reply)
    assert header["ok"] is False
    assert "input 'pressure' has shape (100,), expected (101,)" in header["error"]["message"]
    assert header["error"]["component"] == "solid"


def test_shape_products_cannot_overflow():
    header = msgpack.packb({"v": protocol.VERSION, "op": "ping", "arrays": [
        {"name": "x", "dtype": "float64", "shape": [2**64 - 1]}]})
    with pytest.raises(ProtocolError, match=r"needs 147573952589676412920 bytes but its frame has 8"):
        protocol.decode([header, b"\0" * 8])


def test_duplicate_array_names_are_refused():
    frames = protocol.encode({"op": "ping"}, {"x": np.zeros(2)})
    header = msgpack.unpackb(frames[0])
    header["arrays"] *= 2
    with pytest.raises(ProtocolError, match="array 'x' appears twice in one message"):
        protocol.decode([msgpack.packb(header), frames[1], frames[1]])


@pytest.mark.parametrize("t", ["0.0", None, True, float("nan"), [0.0]])
def test_time_must_be_a_finite_number(t):
    server = ComponentServer(TubeSolid())
    server.handle(protocol.encode({"op": "instantiate", "id": 1, "args": {"parameters": {}}}))
    reply, _ = server.handle(protocol.encode({"op": "step", "id": 2, "args": {"t": t, "dt": 0.1}},
                                             {"pressure": np.zeros(101)}))
    header, _ = protocol.decode(reply)
    assert header["ok"] is False
    assert header["error"]["message"] == f"argument 't' must be a finite number, got {t!r}"


def test_an_oversize_frame_is_dropped_before_it_is_received():
    import zmq

    from cosim.server import bind_socket
    router = bind_socket("tcp://127.0.0.1:*", max_bytes=1024)
    assert bind_socket.__defaults__[0] == protocol.MAX_MESSAGE_BYTES
    endpoint = router.getsockopt_string(zmq.LAST_ENDPOINT)
    big, small = (zmq.Context.instance().socket(zmq.DEALER) for _ in range(2))
    try:
        for dealer in (big, small):
            dealer.setsockopt(zmq.LINGER, 0)
            dealer.connect(endpoint)
        big.send_multipart(protocol.encode({"op": "ping", "id": 1}, {"x": np.zeros(1000)}))
        small.send_multipart(protocol.encode({"op": "ping", "id": 2}))
        assert router.poll(30_000), "the small message did not arrive"
        _, *frames = router.recv_multipart()
        assert protocol.decode(frames)[0]["id"] == 2
        assert not router.poll(200)   # the 8 kB frame never arrives
    finally:
        for socket in (big, small, router):
            socket.close(linger=0)


@pytest.mark.parametrize("dtype", ["int64", "uint8", "bool", "float32"])
def test_an_input_that_is_not_float64_gets_an_error_reply(dtype):
    server = ComponentServer(TubeSolid())
    server.handle(protocol.encode({"op": "instantiate", "id": 1, "args": {"parameters": {}}}))
    for op in ("step", "set_values"):
        reply, stop = server.handle(protocol.encode({"op": op, "id": 2, "args": {"t": 0.0, "dt": 0.1}},
                                                    {"pressure": np.zeros(101, dtype=dtype)}))
        header, arrays = protocol.decode(reply)
        assert header["ok"] is False and not stop and arrays == {}
        assert header["error"]["message"] == f"input 'pressure' is {dtype}; every variable is float64"


def test_a_launched_component_serves_only_the_run_that_launched_it(tmp_path):
    """Any local process reaches a served component's port; only the client with the launcher's run token is
    served, for every operation: a foreign instantiate mid-run would change the physics."""
    import os

    import zmq

    from cosim.launcher import Launcher
    from cosim.proxy import ComponentProxy
    from tests.conftest import children_of

    def ask(socket, op: str, args: dict) -> dict:
        socket.send_multipart(protocol.encode({"op": op, "id": 1, "args": args}))
        assert socket.poll(30_000)
        return protocol.decode(socket.recv_multipart())[0]

    with Launcher(tmp_path) as launcher:
        process = launcher.spawn("solid", "solid_component.tube:TubeSolid")
        endpoint = launcher.handshake(process)
        stranger = zmq.Context.instance().socket(zmq.DEALER)
        stranger.setsockopt(zmq.LINGER, 0)
        stranger.connect(endpoint)
        proxy = ComponentProxy("solid", endpoint, process=process)
        try:
            for op, args in [("shutdown", {}), ("instantiate", {"parameters": {}}), ("ping", {}),
                             ("shutdown", {"token": "0" * 32}), ("instantiate", {"token": process.token[:-1]})]:
                header = ask(stranger, op, args)
                assert header["ok"] is False
                assert header["error"]["message"] == (f"'{op}' refused: only the run that launched this component "
                                                      "may drive it")
            proxy.instantiate({"tube": {}})              # the run is served, and is from now on the one client
            for op, args in [("instantiate", {"parameters": {"E_small": 1.0}, "token": process.token}),
                             ("shutdown", {"token": process.token})]:
                header = ask(stranger, op, args)      # even with the token: the run's client is taken
                assert header["ok"] is False and "this component serves another client" in header["error"]["message"]
            assert process.poll() is None and proxy.variables["section"].size == 101
            with open(f"/proc/{process.pid}/cmdline", "rb") as argv:       # the token is in no argv
                assert process.token.encode() not in argv.read()
        finally:
            stranger.close()
        proxy.shutdown(timeout=30)
        proxy.close()
        assert process.popen.wait(timeout=30) == 0
    assert children_of(os.getpid()) == []


def test_a_component_served_by_hand_serves_the_first_client_that_drives_it(tmp_path):

    from cosim.proxy import ComponentProxy
    from tests.conftest import served_by_hand

    with served_by_hand("solid_component.tube:TubeSolid") as handshake:
        endpoint = handshake["endpoint"]
        run = ComponentProxy("solid", endpoint)
        stranger = ComponentProxy("stranger", endpoint, timeout=30)
        try:
            assert stranger.call("ping")[0]["pid"] > 0         # anyone may ping before the run takes it
            run.instantiate({"tube": {}})
            with pytest.raises(ComponentError, match="'shutdown' failed: ProtocolError: 'shutdown' refused: this "
                                                     "component serves another client"):
                stranger.shutdown(timeout=30)
            run.shutdown(timeout=30)
        finally:
            stranger.close()
            run.close()



def test_check_leaves_a_component_served_by_hand_to_the_run(tmp_path):
    """``cosim check`` pings a component served by hand; the run that follows is still served by it."""
    from cosim.cli import main
    from tests.conftest import TUBE_SCENE, served_by_hand
    with served_by_hand("solid_component.tube:TubeSolid") as handshake:
        address = ["--set", "components.solid.entry=''", "--set", f"components.solid.address='{handshake['endpoint']}'",
                   "--set", "time.end=0.5"]
        assert main(["check", str(TUBE_SCENE), *address]) == 0
        assert main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "run"), "--quiet", *address]) == 0


def test_cosim_serve_finds_a_module_in_the_working_directory(tmp_path):
    from cosim.proxy import ComponentProxy
    from tests.conftest import served_by_hand
    (tmp_path / "my_wall.py").write_text("from solid_component.tube import TubeSolid\n\n\n"
                                         "class MyWall(TubeSolid):\n    name = 'my wall'\n")
    with served_by_hand("my_wall:MyWall", cwd=tmp_path, script=True) as handshake:
        assert handshake["name"] == "my wall"
        proxy = ComponentProxy("wall", handshake["endpoint"])
        proxy.shutdown(timeout=30)
        proxy.close()
