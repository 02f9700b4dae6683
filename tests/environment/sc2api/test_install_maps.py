"""Installing the mini-game maps from the pysc2-evolved source distribution."""

import io
import tarfile

import pytest

from sc2jax.environment.engine.minigames import MAPS
from sc2jax.environment.sc2api import install_maps


def _sdist(path, names):
    with tarfile.open(path, "w:gz") as tar:
        for name in names + ["README.md"]:
            data = f"map {name}".encode()
            info = tarfile.TarInfo(f"pysc2_evolved-1.1.1/src/pysc2_evolved/maps/mini_games/{name}"
                                   if name.endswith(".SC2Map") else f"pysc2_evolved-1.1.1/{name}")
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return path


def test_maps_install_into_the_games_maps_folder(tmp_path, capsys):
    (tmp_path / "sc2" / "Versions").mkdir(parents=True)
    sdist = _sdist(tmp_path / "p.tar.gz", [f"{name}.SC2Map" for name in MAPS])
    assert install_maps.main(["--sc2path", str(tmp_path / "sc2"), "--sdist", str(sdist)]) == 0
    folder = tmp_path / "sc2" / "Maps" / "mini_games"
    assert sorted(p.name for p in folder.iterdir()) == sorted(f"{n}.SC2Map" for n in MAPS)
    assert (folder / "BuildMarines.SC2Map").read_bytes() == b"map BuildMarines.SC2Map"
    assert "installed" in capsys.readouterr().out


def test_a_tarball_without_the_maps_is_rejected(tmp_path):
    sdist = _sdist(tmp_path / "p.tar.gz", ["MoveToBeacon.SC2Map"])
    with pytest.raises(ValueError, match="lacks the mini-game maps.*BuildMarines.SC2Map"):
        install_maps.maps_from_sdist(sdist)
