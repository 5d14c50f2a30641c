"""Pure-numpy reader of OpenVDB ``.vdb`` files (file format versions 222 to 224).

The reader turns one grid of a ``.vdb`` file into a dense numpy array that holds, for
every voxel of a box, the value OpenVDB's own tree would return there: active and
inactive leaf values, tile values of every tree level, and the background elsewhere.

Layout of a file, as far as this module needs it (all little-endian)::

    header      int64 magic 0x56444220, uint32 file version, uint32 library major,
                uint32 library minor, uint8 has-grid-offsets, 36-char UUID,
                file metadata
    grids       int32 count, then per grid: descriptor (unique name, tree type,
                instance parent, int64 grid / block / end offsets) followed by the
                grid: uint32 compression flags, grid metadata, transform,
                topology (root, internal nodes, leaf value masks), leaf buffers

Compressed value arrays start with a per-node metadata byte (how the inactive values
are encoded), optional inactive values and selection mask, then the stored values; a
zip or blosc chunk starts with an int64 byte count (negative: the bytes are stored raw).
"""

from .reader import list_grids, read_grid
from .records import VdbFormatError, VdbGrid, VdbGridInfo

__all__ = ["VdbFormatError", "VdbGrid", "VdbGridInfo", "list_grids", "read_grid"]
