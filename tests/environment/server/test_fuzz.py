"""The server against random well-formed requests (hypothesis): whatever two clients send,
every request gets a parseable reply, a third client then plays a whole episode, and
the memory stays bounded.

Requests are filled field by field from their descriptors. Step counts are any (one
program runs every count); join and replay resolutions are kept at 16² or 24², with or
without raw units, so that the fuzz compiles at most `programs.MAX_FORMATS` program sets
(each other format compiles one more, which would make it slow, not fail). `quit` is
left out (it ends the server; tested in test_server.py).
"""

import functools
import pathlib

import pytest

hypothesis = pytest.importorskip("hypothesis")
from google.protobuf.descriptor import FieldDescriptor  # noqa: E402
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall  # noqa: E402
from sc2jax.environment.sc2api import proto_actions  # noqa: E402
from sc2jax.environment.sc2api.protos import sc2api  # noqa: E402
from sc2jax.environment.server import Sc2ApiServer  # noqa: E402

_F = FieldDescriptor
_SCALARS = {
    _F.CPPTYPE_INT32: st.integers(-2 ** 31, 2 ** 31 - 1),
    _F.CPPTYPE_INT64: st.integers(-2 ** 63, 2 ** 63 - 1),
    _F.CPPTYPE_UINT32: st.integers(0, 2 ** 32 - 1),
    _F.CPPTYPE_UINT64: st.integers(0, 2 ** 64 - 1),
    _F.CPPTYPE_DOUBLE: st.floats(allow_nan=True, allow_infinity=True),
    _F.CPPTYPE_FLOAT: st.floats(allow_nan=True, allow_infinity=True, width=32),
    _F.CPPTYPE_BOOL: st.booleans(),
    _F.CPPTYPE_STRING: st.text(max_size=12),
}


def _fill(draw, message, depth: int) -> None:
    """Sets a random subset of `message`'s fields to random values."""
    for field in message.DESCRIPTOR.fields:
        if not draw(st.booleans()):
            continue
        repeated = field.is_repeated
        count = draw(st.integers(0, 3)) if repeated else 1
        if field.cpp_type == _F.CPPTYPE_MESSAGE:
            if depth >= 4:
                continue
            for _ in range(count):
                child = getattr(message, field.name).add() if repeated else getattr(
                    message, field.name)
                child.SetInParent()
                _fill(draw, child, depth + 1)
            continue
        if field.cpp_type == _F.CPPTYPE_ENUM:
            values = st.sampled_from([v.number for v in field.enum_type.values])
        elif field.type == _F.TYPE_BYTES:
            values = st.binary(max_size=32)
        else:
            values = _SCALARS[field.cpp_type]
        drawn = [draw(values) for _ in range(count)]
        if repeated:
            getattr(message, field.name).extend(drawn)
        else:
            setattr(message, field.name, drawn[0])


@st.composite
def requests(draw):
    # Half the requests are the game's own (action, step, observation), so that the fuzz
    # reaches the game as often as its parser.
    kind = draw(st.one_of(st.sampled_from(["action", "step", "observation"]), st.sampled_from(
        [f.name for f in sc2api.Request.DESCRIPTOR.oneofs_by_name["request"].fields
         if f.name != "quit"])))
    request = sc2api.Request()
    getattr(request, kind).SetInParent()
    _fill(draw, getattr(request, kind), 1)
    if draw(st.booleans()):
        request.id = draw(st.integers(0, 2 ** 32 - 1))
    if kind in ("join_game", "start_replay"):
        layers = getattr(request, kind).options.feature_layer
        size = draw(st.sampled_from([16, 24]))
        layers.resolution.x = layers.resolution.y = size
        layers.minimap_resolution.x = layers.minimap_resolution.y = size
        getattr(request, kind).options.raw = draw(st.booleans())
    if kind == "step" and request.step.HasField("count"):
        request.step.count = draw(st.one_of(st.integers(1, 10_000),
                                            st.integers(0, 2 ** 32 - 1)))
    return request


SERVER = Sc2ApiServer(port=0)  # Not listening: requests go to `answer` in process.
GOOD = object()


def _ask(server, client, **kind):
    reply = sc2api.Response.FromString(server.answer(
        sc2api.Request(**kind).SerializeToString(), client)[0])
    assert not reply.error, reply.error
    return reply


def _join(server, client) -> None:
    """`client` creates MoveToBeacon and joins it at 16²."""
    ask = functools.partial(_ask, server, client)
    create = sc2api.RequestCreateGame(
        local_map=sc2api.LocalMap(map_path="MoveToBeacon.SC2Map"),
        player_setup=[sc2api.PlayerSetup(type=sc2api.PlayerType.Value("Participant"))])
    ask(create_game=create)
    options = sc2api.InterfaceOptions()
    layers = options.feature_layer
    layers.width, layers.resolution.x, layers.resolution.y = 24, 16, 16
    layers.minimap_resolution.x = layers.minimap_resolution.y = 16
    ask(join_game=sc2api.RequestJoinGame(options=options))


def _play(server) -> None:
    """A correct client creates a game, joins, plays it to its end, and leaves."""
    ask = functools.partial(_ask, server, GOOD)
    _join(server, GOOD)
    army = proto_actions.to_proto(FunctionCall(FUNCTIONS.select_army.id, [[0]]))
    loops = 0
    while True:
        ask(action=sc2api.RequestAction(actions=[army]))
        loops += 256
        assert ask(step=sc2api.RequestStep(count=256)).step.simulation_loop == loops
        observed = ask(observation=sc2api.RequestObservation()).observation
        assert observed.observation.game_loop == loops
        if observed.player_result:
            break
    ask(leave_game=sc2api.RequestLeaveGame())


def _rss_mb() -> float:
    pages = int(pathlib.Path("/proc/self/statm").read_text().split()[1])
    return pages * 4096 / 2 ** 20


@pytest.mark.slow
@pytest.mark.skipif(not pathlib.Path("/proc/self/statm").exists(), reason="Linux only")
def test_random_requests_from_two_clients_never_break_the_game():
    _play(SERVER)  # Compiles the programs the correct client needs.
    before = _rss_mb()

    @settings(max_examples=150, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(st.booleans(), st.lists(st.tuples(st.sampled_from(["a", "b"]), requests()),
                                   min_size=1, max_size=6))
    def any_requests(in_game, sent):
        if in_game:  # Client a owns a game the requests then reach.
            _join(SERVER, "a")
        for client, request in sent:
            reply = sc2api.Response.FromString(
                SERVER.answer(request.SerializeToString(), client)[0])
            assert reply.status  # Always a status, so a client can go on.
            kind = request.WhichOneof("request")
            own = getattr(reply, kind)
            if not reply.error and not ("error" in own.DESCRIPTOR.fields_by_name
                                        and own.HasField("error")):
                answered.add(kind)
        for client in ("a", "b"):  # Both disconnect: whatever they own is left.
            SERVER.gone(client)
        _play(SERVER)

    answered = set()
    any_requests()
    assert _rss_mb() - before < 300, (before, _rss_mb())
    # The fuzz reached the game, not only the parser's errors.
    assert {"action", "step", "observation"} <= answered, sorted(answered)
