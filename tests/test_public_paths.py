"""The public import paths and commands that users rely on keep working after the layout
change, the deprecated module paths warn, and the networks and losses import without
the simulator."""

import subprocess
import sys
import textwrap

import pytest


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, timeout=300)


def test_the_public_names_import():
    out = _run("""
        from sc2jax.environment import (FUNCTIONS, MINIMAP_FEATURES, SCREEN_FEATURES, TYPES,
                                        Simulator, make, over_devices, to_dense, MAPS)
        from sc2jax.networks import make_network, AtariNet, FullyConv, FullyConvLSTM, ARFullyConv
        from sc2jax.losses import make_actor_critic_loss, unroll
        assert len(FUNCTIONS) == 573 and len(TYPES) == 13 and len(MAPS) == 7
        assert len(SCREEN_FEATURES) == 27 and len(MINIMAP_FEATURES) == 11
        import sc2jax.environment as env
        assert set(["make", "Simulator", "over_devices"]) <= set(dir(env))
        try:
            env.no_such_name
        except AttributeError as e:
            assert "no_such_name" in str(e)
        print("ok")
    """)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


def test_an_empty_compilation_cache_flag_turns_the_cache_off_everywhere():
    out = _run("""
        import os
        os.environ.pop("JAX_COMPILATION_CACHE_DIR", None)  # the tests' own cache
        os.environ.pop("SC2JAX_COMPILATION_CACHE", None)
        import jax
        from sc2jax.experiments.training import flags as training_flags
        from sc2jax.environment.engine.xla.compilation_cache import use_compilation_cache
        training_flags.define_training()
        training_flags.FLAGS(["cmd", "--compilation_cache="])
        training_flags.start_command()
        assert use_compilation_cache() is None  # what `make` calls
        assert not jax.config.jax_compilation_cache_dir
        assert os.environ["SC2JAX_COMPILATION_CACHE"] == "0"  # child processes
        print("ok")
    """)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


def test_networks_and_losses_import_without_the_simulator():
    out = _run("""
        import sys
        import sc2jax.networks, sc2jax.losses
        loaded = [m for m in sys.modules if m.startswith("sc2jax.environment.")]
        assert not [m for m in loaded if m.split(".")[2] != "interface"], loaded
        print("ok")
    """)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


@pytest.mark.parametrize("old,new", [("environments", "sc2_env"),
                                     ("simulator", "engine.simulator")])
def test_the_old_module_paths_warn_and_still_work(old, new):
    out = _run(f"""
        import warnings
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            import sc2jax.environment.{old} as module
        assert any(issubclass(w.category, DeprecationWarning) and "sc2jax.environment.{new}"
                   in str(w.message) for w in caught), [str(w.message) for w in caught]
        assert module.{"make" if old == "environments" else "Simulator"} is not None
        print("ok")
    """)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


def test_a_preset_sets_the_config_and_a_given_flag_overrides_it():
    out = _run("""
        from absl import flags
        from sc2jax.experiments.training import flags as training_flags
        from sc2jax.experiments.training.config import TrainConfig
        from sc2jax.experiments.training.presets import PRESETS
        training_flags.define_training()
        FLAGS = flags.FLAGS
        FLAGS(["x", "--preset=beacon_quickstart", "--seed=3"])
        config = training_flags.config_from_flags()
        expected = PRESETS["beacon_quickstart"].config
        assert config.seed == 3 and config.screen_size == 16 == expected.screen_size
        assert config.functions == ("no_op", "select_army", "Move_screen"), config.functions
        assert config.total_steps == 96000 and config.learning_rate == 5e-3
        FLAGS.unparse_flags(); FLAGS(["x"])
        assert training_flags.config_from_flags() == TrainConfig()
        FLAGS.unparse_flags(); FLAGS(["x", "--preset=nope"])
        try:
            training_flags.config_from_flags()
        except ValueError as e:
            assert "unknown preset 'nope'; allowed" in str(e) and "beacon_quickstart" in str(e)
        else:
            raise AssertionError("no error for an unknown preset")
        assert len(PRESETS) == 9 and all(p.config.map_name for p in PRESETS.values())
        # --network names the architecture; the old --agent and PySC2's names still work.
        for args in (["--network=atari", "--screen_size=32", "--minimap_size=24"],
                     ["--agent=atari", "--feature_screen_size=32",
                      "--feature_minimap_size=24"]):
            FLAGS.unparse_flags(); FLAGS(["x", *args])
            config = training_flags.config_from_flags()
            assert (config.agent, config.screen_size, config.minimap_size) == (
                "atari", 32, 24), (args, config)
        # The persistent compilation cache: on at --compilation_cache, off with ''.
        import jax
        FLAGS.unparse_flags(); FLAGS(["x", "--compilation_cache=/tmp/sc2jax-test-cache"])
        training_flags.start_command()
        assert jax.config.jax_compilation_cache_dir == "/tmp/sc2jax-test-cache"
        print("ok")
    """)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


@pytest.mark.slow
@pytest.mark.parametrize("command", [
    "sc2jax.experiments.train", "sc2jax.experiments.evaluate", "sc2jax.experiments.sweep",
    "sc2jax.experiments.table1", "sc2jax.experiments.random_search",
    "sc2jax.experiments.benchmark", "sc2jax.experiments.benchmark_networks",
    "sc2jax.experiments.benchmark_training", "sc2jax.experiments.benchmark_protocol",
    "sc2jax.experiments.replay_info", "sc2jax.experiments.convert_replays",
    "sc2jax.experiments.train_replays", "sc2jax.experiments.record_demonstrations",
    "sc2jax.experiments.playback_replays", "sc2jax.experiments.play",
    "sc2jax.environment.server"])
def test_every_command_starts(command):
    out = subprocess.run([sys.executable, "-m", command, "--help"], capture_output=True,
                         text=True, timeout=300)
    # absl's --help exits with 1 after printing the flags; argparse's with 0.
    assert out.returncode in (0, 1) and "Traceback" not in out.stderr, out.stderr[-2000:]
    assert "--" in out.stdout, out.stdout[-2000:]  # its flags


@pytest.mark.slow
@pytest.mark.parametrize("args, message", [
    (["sc2jax.experiments.evaluate", "--screen_size=-16"],
     "error: screen_size must be in [16, 256] pixels per side, got -16"),
    (["sc2jax.experiments.train", "--run_dir=FILE"], "is a file; give a directory"),
    (["sc2jax.experiments.train", "--functions=no_op,Move_scren"],
     "unknown function 'Move_scren'; give PySC2 names or ids 0..572; did you mean "
     "Move_screen"),
    (["sc2jax.experiments.train_replays", "--dataset=FILE"], "is not a converted dataset"),
    (["sc2jax.experiments.table1", "--map=MoveToBeacon"],
     "error: table1 takes --maps (comma-separated, or 'all'), not --map"),
])
def test_bad_flags_give_one_line_errors(tmp_path, args, message):
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    args = [a.replace("FILE", str(a_file)) for a in args]
    out = subprocess.run([sys.executable, "-m", *args], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode != 0 and "Traceback" not in out.stderr, out.stderr[-2000:]
    assert message in out.stderr, out.stderr[-2000:]
