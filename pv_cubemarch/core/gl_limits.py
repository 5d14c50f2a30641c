"""The GL limits the techniques plan for before a window exists (checked again at upload)."""

#: Largest 3D texture edge assumed (GL_MAX_3D_TEXTURE_SIZE on llvmpipe and many GPUs).
MAX_TEXTURE_SIZE = 2048
#: Most label bytes drawn as one grid: beyond, a grid is drawn in chunks. Its level atlas
#: is up to 1.5x the labels and its upload makes one more copy; llvmpipe here refused 3D
#: textures over about 1.8 GB (GL_OUT_OF_MEMORY, which VTK's upload does not report).
MAX_GRID_BYTES = 512 * 2**20
