"""The StarCraft II API's protobuf messages, on protobuf's fast runtime.

`s2clientprotocol`'s generated `*_pb2` modules only import with protobuf <= 3.20 or in
protobuf's slow pure-Python mode. This module never imports them: it reads each module's
serialized `FileDescriptorProto` out of its source, adds them to a private descriptor
pool, and builds the message classes from it, so parsing stays in the compiled runtime.

    from sc2jax.environment.sc2api.protos import sc2api
    request = sc2api.Request(id=1, ping=sc2api.RequestPing())
    sc2api.Status.Value("in_game")   # 3

Messages and enums of package `SC2APIProtocol` are attributes of `sc2api` by their
short names (nested ones through their parents, e.g. `sc2api.ResponseCreateGame.Error`).
"""

from __future__ import annotations

import ast
import functools
import importlib.util
import pathlib

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.internal import api_implementation, enum_type_wrapper

PACKAGE = "SC2APIProtocol"


def _serialized_descriptor(source: str, path: pathlib.Path) -> bytes:
    """The `serialized_pb` bytes of a generated `_pb2` module's source."""
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.keyword) and node.arg == "serialized_pb":
            value = node.value.args[0] if isinstance(node.value, ast.Call) else node.value
            value = ast.literal_eval(value)
            return value.encode("latin1") if isinstance(value, str) else value
    raise RuntimeError(f"no serialized_pb descriptor in {path}; this s2clientprotocol "
                       f"version is not supported")


@functools.cache
def _pool() -> descriptor_pool.DescriptorPool:
    spec = importlib.util.find_spec("s2clientprotocol")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("the StarCraft II API needs s2clientprotocol: pip install "
                          "s2clientprotocol")
    root = pathlib.Path(list(spec.submodule_search_locations)[0])
    files = {}
    for path in sorted(root.glob("*_pb2.py")):
        proto = descriptor_pb2.FileDescriptorProto.FromString(
            _serialized_descriptor(path.read_text(), path))
        files[proto.name] = proto
    pool = descriptor_pool.DescriptorPool()
    added: set[str] = set()

    def add(name: str):
        if name in added:
            return
        for dependency in files[name].dependency:
            add(dependency)
        pool.Add(files[name])
        added.add(name)

    for name in files:
        add(name)
    return pool


class _Namespace:
    """Message classes and enum wrappers of `SC2APIProtocol`, by short name."""

    def __getattr__(self, name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        value = _lookup(name)
        setattr(self, name, value)
        return value


def _lookup(name: str):
    pool, full = _pool(), f"{PACKAGE}.{name}"
    try:
        return message_factory.GetMessageClass(pool.FindMessageTypeByName(full))
    except KeyError:
        pass
    try:
        return enum_type_wrapper.EnumTypeWrapper(pool.FindEnumTypeByName(full))
    except KeyError:
        raise AttributeError(f"the StarCraft II API has no message or enum {name!r}") from None


sc2api = _Namespace()
"""Every message and enum of the StarCraft II API (all of s2clientprotocol's files)."""


def runtime() -> str:
    """protobuf's runtime: 'upb' or 'cpp' (fast) or 'python' (slow)."""
    return api_implementation.Type()
