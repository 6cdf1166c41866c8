"""City scale: step 1 and ground over many tiles with a buffer, out of core, on Dask.

A city does not fit one file nor one machine's memory (step 1 needs about
140 bytes per point).  This module runs step 1 (:func:`pyheracles.complex.segment_complex`)
and the ground filter tile by tile, each tile with a buffer of its neighbours' points,
and merges the results so that an object crossing a tile edge comes out whole and once.

Catalogue
    :func:`read_catalog` takes a glob (``tiles/*.laz``), a folder, or a tile index
    GeoPackage (one row per file, the path in a ``location`` / ``path`` / ``filename``
    field, as ``gdaltindex``, PDAL ``tindex`` and lidR catalogs write).  Each tile's
    bounds come from its LAS header (no point is read); the CRS is checked across
    tiles; duplicate tiles (same bounds and point count, or boxes overlapping by more
    than half) are refused by name; unreadable tiles are reported by name and the
    others are processed.

Buffer
    A tile is processed with the points of the other tiles inside its read box: the
    tile's box grown by ``buffer_m``, widened to hold every feature the tile owns grown
    by twice the cookie-cutter buffer (so an owned object is always whole, however
    large).  The automatic ``buffer_m`` is half the largest object plus 5 m, at least
    20 m: the ground filter's window (half the largest object plus a cell) around the
    tile, so the DTM has no seam.  Points are read by chunks with laspy, so memory stays
    bounded by the tile plus its buffer; COPC files are read the same way (a COPC query
    by bounds returns points in octree order and would lose the file order the outputs
    keep).

Ownership rule
    Each GIS feature belongs to exactly ONE tile: the tile whose box contains the
    feature's representative point (``shapely.point_on_surface``, always inside the
    polygon, unlike the centroid of an L-shaped building); on a shared edge, or where
    boxes overlap, the tile whose centre is nearest; a point in no box goes to the
    nearest box.  The owning tile's run (with its buffer) gives the object's points in
    every tile; other tiles' runs use the feature only so that it competes for points
    as in a single run.

Phases
    0. per tile (a Dask task): read the tile once and keep, uncompressed, the points inside
       its neighbours' read boxes (``.work/strips/<tile>.npz``), so that a buffer costs a
       load instead of decompressing a neighbour's whole file (nine files per tile on a
       grid); removed once every tile has passed phase 1;
    1. per tile: read the tile and its buffer, ground and step 1, and
       save the owned objects with their members as (tile, index in that tile's file)
       plus the ground mask of the tile's own points in ``.work/<tile>.pkl``;
    2. per tile: the tile's own points (read again with every dimension), labelled by
       the owners of the objects touching it, written to ``tiles/<tile>/segmented.laz``
       (exactly the tile's points, in file order, every input dimension kept) with its
       ``objects.gpkg`` and ``run.json``; the folder is built beside and renamed into
       place, so a finished tile is whole or absent.  Finally ``objects.gpkg`` (all
       objects, global ``instance`` ids, ``n_points`` over all tiles, the owning
       ``tile``) and ``tiles.gpkg`` (the tile index with each tile's status).

    Conflicts between runs (rare, at the edges of buffers): a point claimed by objects
    of two owners goes to the first owner in catalogue order; a point one tile's ground
    filter calls ground but the owning run put in an object stays in the object.

Parameters measured once
    The automatic parameters (step 1's distances from the point spacing, the ground
    filter's cell and window) are measured once for the whole city on a sample of tiles
    and given to every tile; the ground rasters have world-aligned cells
    (:func:`pyheracles.ground.aligned_grid`, as the single-cloud run), so a tile's
    ground and labels are those of a single run over the whole area.

Ground over tiles
    :func:`run_ground_tiles` runs the ground filter per tile with the same buffer and
    writes ``tiles/<tile>/ground.laz`` and ``dtm.tif`` (the tile's own box, on the
    world-aligned cells) and ``dtm.vrt``, a GDAL virtual mosaic of the tiles' DTMs:
    one seamless terrain model.

Resume
    A tile whose strip, phase-1 file or ``tiles/<tile>/`` folder exists is not computed
    again;
    outputs are deterministic, so a resumed run gives the same files.

Modules: :mod:`~pyheracles.tiles.catalog` (input), :mod:`~pyheracles.tiles.plan`
(owners, buffers, parameters), :mod:`~pyheracles.tiles.worker` (the tasks),
:mod:`~pyheracles.tiles.merge` (tables, index), :mod:`~pyheracles.tiles.runner` (Dask),
:mod:`~pyheracles.tiles.ground` (the DTM mosaic).
"""

from pyheracles.tiles.catalog import Tile, TileCatalog, is_tile_source, read_catalog, split_las
from pyheracles.tiles.ground import GroundTilesResult, run_ground_tiles, write_vrt
from pyheracles.tiles.plan import CityParameters, assign_owners, city_parameters
from pyheracles.tiles.runner import TiledResult, run_tiles

__all__ = [
    "CityParameters",
    "GroundTilesResult",
    "Tile",
    "TileCatalog",
    "TiledResult",
    "assign_owners",
    "city_parameters",
    "is_tile_source",
    "read_catalog",
    "run_ground_tiles",
    "run_tiles",
    "split_las",
    "write_vrt",
]
