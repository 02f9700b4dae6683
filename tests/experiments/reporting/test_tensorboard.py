"""Tests for the dependency-free TensorBoard event writer, read back by TensorBoard itself."""

import math
import os
import struct

import numpy as np
import pytest

from sc2jax.experiments.reporting import tensorboard


def test_crc32c_check_value():
    # The standard CRC-32C check value (RFC 3720, B.4): crc32c("123456789") = 0xE3069283.
    assert tensorboard.crc32c(b"123456789") == 0xE3069283
    assert tensorboard.crc32c(b"") == 0


def test_masked_crc32c_matches_tensorboard():
    from tensorboard.compat.tensorflow_stub import pywrap_tensorflow

    for data in (b"", b"123456789", bytes(range(256)) * 3):
        assert tensorboard.masked_crc32c(data) == pywrap_tensorflow.masked_crc32c(data)


def test_tfrecord_framing():
    record = tensorboard.tfrecord(b"abc")
    # 8 length bytes + 4 crc + 3 data + 4 crc.
    assert len(record) == 19
    assert struct.unpack("<Q", record[:8]) == (3,)
    assert struct.unpack("<I", record[8:12]) == (tensorboard.masked_crc32c(record[:8]),)
    assert record[12:15] == b"abc"
    assert struct.unpack("<I", record[15:]) == (tensorboard.masked_crc32c(b"abc"),)


def test_event_encoding_by_hand():
    data = tensorboard.encode_event(0.0, 300, values={"a": 1.0})
    # wall_time: tag 0x09 + 8 zero bytes; step 300 = 0b10_0101100 -> varint 0xAC 0x02;
    # summary (field 5, 0x2A) of one value (0x0A) = tag "a" (0x0A 0x01 'a') + float 1.0 (0x15).
    value = b"\x0a\x01a" + b"\x15" + struct.pack("<f", 1.0)
    summary = b"\x0a" + bytes([len(value)]) + value
    expected = b"\x09" + bytes(8) + b"\x10\xac\x02" + b"\x2a" + bytes([len(summary)]) + summary
    assert data == expected


def _read(logdir):
    from tensorboard.backend.event_processing import event_accumulator

    acc = event_accumulator.EventAccumulator(str(logdir))
    acc.Reload()
    return acc


def test_scalars_read_back_by_tensorboard(tmp_path):
    logdir = tmp_path / "run"
    with tensorboard.SummaryWriter(logdir) as writer:
        writer.scalar("loss", 0.5, step=1)
        writer.scalars({"loss": 0.25, "score/mean": np.float32(21.5)}, step=np.int64(2))
        writer.scalars({"score/mean": float("nan"), "big": 1e300}, step=2**40)
        writer.scalar("neg_step", -1.25, step=-3)
    (name,) = os.listdir(logdir)
    assert name.startswith("events.out.tfevents.")
    acc = _read(logdir)
    assert sorted(acc.Tags()["scalars"]) == ["big", "loss", "neg_step", "score/mean"]
    assert [(e.step, e.value) for e in acc.Scalars("loss")] == [(1, 0.5), (2, 0.25)]
    score = acc.Scalars("score/mean")
    assert [e.step for e in score] == [2, 2**40]
    assert score[0].value == 21.5 and math.isnan(score[1].value)
    assert acc.Scalars("big")[0].value == math.inf
    assert [(e.step, e.value) for e in acc.Scalars("neg_step")] == [(-3, -1.25)]
    assert acc.file_version == 2.0


def test_second_writer_gets_its_own_file(tmp_path):
    with tensorboard.SummaryWriter(tmp_path) as a, tensorboard.SummaryWriter(tmp_path) as b:
        a.scalar("x", 1.0, 0)
        b.scalar("x", 2.0, 1)
    assert a.path != b.path and len(os.listdir(tmp_path)) == 2
    assert sorted(e.value for e in _read(tmp_path).Scalars("x")) == [1.0, 2.0]


def test_bad_input(tmp_path):
    writer = tensorboard.SummaryWriter(tmp_path)
    with pytest.raises(TypeError, match="step must be an integer"):
        writer.scalar("x", 1.0, step=1.5)
    with pytest.raises(TypeError, match="real number"):
        writer.scalar("x", "high", step=1)
    with pytest.raises(ValueError, match="non-empty"):
        writer.scalar("", 1.0, step=1)
    writer.close()
    writer.close()
    with pytest.raises(ValueError, match="closed"):
        writer.scalar("x", 1.0, step=1)
