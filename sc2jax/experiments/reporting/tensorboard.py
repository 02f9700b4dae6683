"""A minimal, dependency-free TensorBoard event-file writer for scalars.

An event file is a sequence of TFRecord records, each

    uint64 length (little-endian) | uint32 masked_crc32c(length bytes)
    | data | uint32 masked_crc32c(data)

whose data is a serialized `tensorflow.Event` protobuf. The few messages needed are
encoded here by hand (proto3 wire format):

    Event   { double wall_time = 1; int64 step = 2; string file_version = 3;
              Summary summary = 5; }
    Summary { repeated Value value = 1; }
    Value   { string tag = 1; float simple_value = 2; }

The first record carries `file_version = "brain.Event:2"`; every `scalar`/`scalars` call
adds one event. Values are stored as float32: NaN stays NaN, and finite values beyond the
float32 range become +-inf.

    with SummaryWriter("runs/a3c") as writer:
        writer.scalars({"loss": 0.5, "score/mean": 21.0}, step=1000)
"""

from __future__ import annotations

import math
import operator
import os
import socket
import struct
import time
from collections.abc import Mapping

FILE_VERSION = "brain.Event:2"
_FLOAT32_MAX = 3.4028234663852886e38


def _crc32c_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x82F63B78 if crc & 1 else crc >> 1  # Castagnoli, reflected.
        table.append(crc)
    return tuple(table)


_CRC32C_TABLE = _crc32c_table()


def crc32c(data: bytes) -> int:
    """CRC-32C (Castagnoli) of `data`, e.g. `crc32c(b"123456789") == 0xE3069283`."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc = _CRC32C_TABLE[(crc ^ byte) & 0xFF] ^ (crc >> 8)
    return crc ^ 0xFFFFFFFF


def masked_crc32c(data: bytes) -> int:
    """The TFRecord checksum: crc32c rotated right by 15 bits plus 0xa282ead8 (mod 2**32)."""
    crc = crc32c(data)
    return (((crc >> 15) | (crc << 17)) + 0xA282EAD8) & 0xFFFFFFFF


def tfrecord(data: bytes) -> bytes:
    """`data` framed as one TFRecord record."""
    length = struct.pack("<Q", len(data))
    return (length + struct.pack("<I", masked_crc32c(length)) + data
            + struct.pack("<I", masked_crc32c(data)))


def _varint(value: int) -> bytes:
    value &= 0xFFFFFFFFFFFFFFFF  # Negative int64s take ten bytes, as in protobuf.
    out = bytearray()
    while value > 0x7F:
        out.append(value & 0x7F | 0x80)
        value >>= 7
    out.append(value)
    return bytes(out)


def _length_delimited(field: int, payload: bytes) -> bytes:
    return _varint(field << 3 | 2) + _varint(len(payload)) + payload


def _float32(value: float) -> bytes:
    if math.isfinite(value) and abs(value) > _FLOAT32_MAX:
        value = math.copysign(math.inf, value)
    return struct.pack("<f", value)


def encode_event(wall_time: float, step: int, *, file_version: str | None = None,
                 values: Mapping[str, float] | None = None) -> bytes:
    """A serialized `Event` with an optional file version and a summary of simple values."""
    data = _varint(1 << 3 | 1) + struct.pack("<d", wall_time) + _varint(2 << 3) + _varint(step)
    if file_version is not None:
        data += _length_delimited(3, file_version.encode())
    if values:
        summary = b"".join(
            _length_delimited(1, _length_delimited(1, tag.encode())
                              + _varint(2 << 3 | 5) + _float32(value))
            for tag, value in values.items())
        data += _length_delimited(5, summary)
    return data


class SummaryWriter:
    """Writes scalar summaries to a new event file in `logdir`.

    Records are buffered; call `flush` (or `close`, or leave the `with` block) to make them
    visible to TensorBoard.

    Args:
      logdir: directory for the event file (created if missing). The file is named
        `events.out.tfevents.<int wall time>.<hostname>`, with `.1`, `.2`, ... appended
        if that name is taken.
    """

    def __init__(self, logdir: str | os.PathLike):
        os.makedirs(logdir, exist_ok=True)
        name = f"events.out.tfevents.{int(time.time())}.{socket.gethostname()}"
        base = os.path.join(logdir, name)
        self.path, suffix = base, 0
        while True:
            try:
                self._file = open(self.path, "xb")  # Closed by close().
                break
            except FileExistsError:
                suffix += 1
                self.path = f"{base}.{suffix}"
        self._file.write(tfrecord(encode_event(time.time(), 0, file_version=FILE_VERSION)))
        self._file.flush()

    def scalar(self, tag: str, value: float, step: int) -> None:
        """Adds one scalar `value` named `tag` at `step` (see `scalars`)."""
        self.scalars({tag: value}, step)

    def scalars(self, values: Mapping[str, float], step: int) -> None:
        """Adds one event holding every `tag: value` of `values` at `step`.

        Args:
          values: non-empty tags mapped to real numbers (Python, NumPy or 0-d JAX scalars).
          step: the global step (an integer).

        Raises:
          ValueError: if the writer is closed or a tag is empty.
          TypeError: if `step` is not an integer, a tag is not a string or a value is not
            a real number.
        """
        if self._file.closed:
            raise ValueError(f"SummaryWriter for {self.path!r} is closed.")
        try:
            step = operator.index(step)
        except TypeError as e:
            raise TypeError(f"step must be an integer, got {step!r}.") from e
        floats = {}
        for tag, value in values.items():
            if not isinstance(tag, str):
                raise TypeError(f"Tags must be strings, got {tag!r}.")
            if not tag:
                raise ValueError("Tags must be non-empty strings, got ''.")
            try:
                floats[tag] = float(value)
            except (TypeError, ValueError) as e:
                raise TypeError(f"Value of {tag!r} must be a real number, got {value!r}.") from e
        if floats:
            self._file.write(tfrecord(encode_event(time.time(), step, values=floats)))

    def flush(self) -> None:
        """Writes buffered events to disk."""
        if not self._file.closed:
            self._file.flush()

    def close(self) -> None:
        """Flushes and closes the event file (closing twice is harmless)."""
        self._file.close()

    def __enter__(self) -> SummaryWriter:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()
