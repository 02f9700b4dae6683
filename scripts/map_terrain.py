"""Reads the terrain of the seven mini-game map files (reference/maps.md) and prints
what the simulator's terrain layers rest on: whether the height, cliff-level and cell-flag
grids are uniform over each map.

The maps come from the pysc2-evolved source distribution, as `install_maps` gets them;
reading the MPQ archives needs `mpyq` (not a dependency of sc2jax):

    pip install mpyq
    python scripts/map_terrain.py [--sdist pysc2_evolved-1.1.1.tar.gz]

The grid files' layouts, as found in these maps (little-endian; no public spec):
- t3SyncHeightMap: "SMAP", a 64-byte header with the vertex grid's width and height
  (65 x 65) at bytes 8..15, then one uint32 per vertex;
- t3SyncCliffLevel: "CLIF", the cell grid's width and height (64 x 64) at bytes 8..15,
  then one uint16 per cell after a 32-byte header;
- t3CellFlags: "LFCT", the cell grid's width and height at bytes 24..31, then one byte
  per cell.
"""

import argparse
import io
import tempfile

import mpyq
import numpy as np

from sc2jax.environment.sc2api.install_maps import download_sdist, maps_from_sdist


def _grid(data: bytes, size_at: int, dtype: str) -> np.ndarray:
    width, height = np.frombuffer(data[size_at:size_at + 8], "<u4")
    cells = int(width) * int(height)
    item = np.dtype(dtype).itemsize
    return np.frombuffer(data[len(data) - cells * item:], dtype).reshape(height, width)


def terrain(map_bytes: bytes) -> dict[str, np.ndarray]:
    """The map's sync height (per vertex), cliff level and cell flags (per cell)."""
    archive = mpyq.MPQArchive(io.BytesIO(map_bytes))
    return {"t3SyncHeightMap": _grid(archive.read_file(b"t3SyncHeightMap"), 8, "<u4"),
            "t3SyncCliffLevel": _grid(archive.read_file(b"t3SyncCliffLevel"), 8, "<u2"),
            "t3CellFlags": _grid(archive.read_file(b"t3CellFlags"), 24, "u1")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sdist", help="a local pysc2-evolved source tarball")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        maps = maps_from_sdist(args.sdist or download_sdist(tmp))
    for name, data in sorted(maps.items()):
        grids = terrain(data)
        summary = ", ".join(
            f"{key} {grid.shape[1]}x{grid.shape[0]} "
            + (f"uniform {grid.flat[0]}" if (grid == grid.flat[0]).all()
               else f"{len(np.unique(grid))} values in {grid.min()}..{grid.max()}")
            for key, grid in grids.items())
        print(f"{name}: {summary}")


if __name__ == "__main__":
    main()
