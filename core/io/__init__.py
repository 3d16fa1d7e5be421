"""File formats at the edges: BOP, original YCB-Video, meshes, images, results CSV."""
