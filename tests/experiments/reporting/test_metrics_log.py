"""Tests for the resumable CSV log and the progress reporter."""

import io
import math

import numpy as np
import pytest

from sc2jax.experiments.reporting.metrics_log import CsvLog, Progress, read_csv


def test_csv_roundtrip(tmp_path):
    path = tmp_path / "metrics.csv"
    with CsvLog(path) as log:
        log.write({"step": 10, "loss": 0.1, "score": np.float32(2.5)})
        log.write({"step": np.int64(20), "loss": float("nan")})  # "score" missing: empty.
        log.write({"step": 30, "loss": float("inf"), "score": None})
    assert path.read_text().splitlines() == [
        "step,loss,score", "10,0.1,2.5", "20,nan,", "30,inf,"]
    columns = read_csv(path)
    assert list(columns) == ["step", "loss", "score"]
    np.testing.assert_array_equal(columns["step"], [10, 20, 30])
    np.testing.assert_array_equal(columns["loss"], [0.1, np.nan, np.inf])
    np.testing.assert_array_equal(columns["score"], [2.5, np.nan, np.nan])


def test_rows_are_flushed_at_once(tmp_path):
    path = tmp_path / "metrics.csv"
    log = CsvLog(path, fieldnames=["step", "x"])
    assert path.read_text() == "step,x\n"
    log.write({"step": 1, "x": 3})
    assert path.read_text() == "step,x\n1,3\n"
    log.close()


def test_extra_keys_raise_and_name_them(tmp_path):
    with CsvLog(tmp_path / "m.csv") as log:
        log.write({"step": 1, "loss": 0.5})
        with pytest.raises(ValueError, match=r"\['lr', 'beta'\] are not columns"):
            log.write({"step": 2, "lr": 1e-3, "beta": 0.1})
        with pytest.raises(TypeError, match="'loss' must be a real number"):
            log.write({"step": 2, "loss": "low"})


def test_resume_drops_truncated_line_and_rows_after_checkpoint(tmp_path):
    path = tmp_path / "metrics.csv"
    # A run logged steps 100..400, then crashed in the middle of writing step 500.
    path.write_text("step,loss\n100,1.0\n200,0.5\n300,0.25\n400,0.125\n500,0.06")
    # It restarts from the checkpoint at step 300: rows for 400 (and the cut 500) go.
    with CsvLog(path, resume_step=300) as log:
        assert log.fieldnames == ["step", "loss"]
        assert path.read_text() == "step,loss\n100,1.0\n200,0.5\n300,0.25\n"
        log.write({"step": 400, "loss": 0.1})
    np.testing.assert_array_equal(read_csv(path)["step"], [100, 200, 300, 400])
    np.testing.assert_array_equal(read_csv(path)["loss"], [1.0, 0.5, 0.25, 0.1])


def test_resume_without_file_or_header_starts_afresh(tmp_path):
    path = tmp_path / "metrics.csv"
    with CsvLog(path, resume_step=5) as log:
        log.write({"step": 1})
    path.write_text("ste")  # A crash while writing the header.
    with CsvLog(path, resume_step=5) as log:
        log.write({"step": 2})
    assert path.read_text() == "step\n2\n"


def test_resume_checks_header(tmp_path):
    path = tmp_path / "metrics.csv"
    path.write_text("step,loss\n1,2\n")
    with pytest.raises(ValueError, match="differs from fieldnames"):
        CsvLog(path, fieldnames=["step", "score"], resume_step=1)
    path.write_text("time,loss\n1,2\n")
    with pytest.raises(ValueError, match="no 'step'"):
        CsvLog(path, resume_step=1)


def test_without_resume_step_the_file_is_replaced(tmp_path):
    path = tmp_path / "metrics.csv"
    path.write_text("step,loss\n1,2\n")
    CsvLog(path).close()
    assert path.read_text() == ""


def test_read_csv_ignores_truncated_line_and_rejects_text(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("step,x\n1,2\n2,")
    np.testing.assert_array_equal(read_csv(path)["x"], [2.0])
    path.write_text("step,x\n1,two\n")
    with pytest.raises(ValueError, match="not a number"):
        read_csv(path)
    path.write_text("")
    with pytest.raises(ValueError, match="no CSV header"):
        read_csv(path)


class FakeClock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_progress_plain_lines_with_rate_eta_and_metrics():
    stream, clock = io.StringIO(), FakeClock()
    progress = Progress(1000, stream=stream, min_interval_s=10, smoothing=0.5, clock=clock,
                        show=["score_mean", "score_max"])
    progress.update(0, {"score_max": 3.0, "loss": 1.0})
    clock.now = 2.0
    progress.update(200, {"score_mean": 1.5, "score_max": 4.0})  # Held back: 2 s < 10 s.
    clock.now = 12.0
    progress.update(400, {"score_mean": 2.0, "score_max": math.nan})
    clock.now = 13.0
    progress.update(500, {"score_mean": 2.25})  # Held back until close().
    progress.close()
    lines = stream.getvalue().splitlines()
    assert len(lines) == 3 and "\r" not in stream.getvalue()
    assert lines[0] == ("  0.0% | 0/1,000 steps | ? steps/s | ETA ? | elapsed 0:00:00"
                        " | score_max=3")
    # Rates: 200/2 = 100, then 200/10 = 20 smoothed 0.5 * 20 + 0.5 * 100 = 60 steps/s;
    # ETA (1000 - 400) / 60 = 10 s.
    assert lines[1] == (" 40.0% | 400/1,000 steps | 60.0 steps/s | ETA 0:00:10 | "
                        "elapsed 0:00:12 | score_mean=2 score_max=nan")
    # 100 / 1 = 100 -> 0.5 * 100 + 0.5 * 60 = 80 steps/s; ETA 500 / 80 = 6.25 s.
    assert lines[2] == (" 50.0% | 500/1,000 steps | 80.0 steps/s | ETA 0:00:06 | "
                        "elapsed 0:00:13 | score_mean=2.25")
    assert progress.steps_per_second == 80.0


def test_progress_redraws_on_a_tty():
    class Tty(io.StringIO):
        def isatty(self):
            return True

    stream, clock = Tty(), FakeClock()
    with Progress(100, stream=stream, clock=clock) as progress:
        progress.update(0, {"score": 12.5})
        clock.now = 1.0
        progress.update(100)
    text = stream.getvalue()
    assert text.startswith("\r[....................]   0.0% | 0/100 steps")
    assert "\r[####################] 100.0% | 100/100 steps | 100 steps/s" in text
    assert text.endswith("\n") and text.count("\n") == 1


def test_progress_bad_arguments():
    with pytest.raises(ValueError, match="total_steps"):
        Progress(0)
    with pytest.raises(ValueError, match="smoothing"):
        Progress(10, smoothing=0)
    with pytest.raises(ValueError, match="min_interval_s"):
        Progress(10, min_interval_s=-1)
