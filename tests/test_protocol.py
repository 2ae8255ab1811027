import msgpack
import numpy as np
import pytest

from cosim import protocol
from cosim.errors import ProtocolError
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


def test_a_launched_component_stops_only_for_the_run_that_launched_it(tmp_path):
    """Any local process reaches a served component's port; only the launcher's run token stops it."""
    import os

    import zmq

    from cosim.launcher import Launcher
    from cosim.proxy import ComponentProxy
    from tests.conftest import children_of
    with Launcher(tmp_path) as launcher:
        process = launcher.spawn("solid", "solid_component.tube:TubeSolid")
        endpoint = launcher.handshake(process)
        stranger = zmq.Context.instance().socket(zmq.DEALER)
        stranger.setsockopt(zmq.LINGER, 0)
        stranger.connect(endpoint)
        try:
            for token in (None, "0" * 32, process.token[:-1]):
                stranger.send_multipart(protocol.encode({"op": "shutdown", "id": 1,
                                                         "args": {} if token is None else {"token": token}}))
                assert stranger.poll(30_000)
                header, _ = protocol.decode(stranger.recv_multipart())
                assert header["ok"] is False
                assert header["error"]["message"] == ("'shutdown' refused: only the run that launched this "
                                                      "component may stop it")
            assert process.poll() is None
            with open(f"/proc/{process.pid}/cmdline", "rb") as argv:       # the token is in no argv
                assert process.token.encode() not in argv.read()
        finally:
            stranger.close()
        proxy = ComponentProxy("solid", endpoint, process=process)
        proxy.shutdown(timeout=30)
        proxy.close()
        assert process.popen.wait(timeout=30) == 0
    assert children_of(os.getpid()) == []
