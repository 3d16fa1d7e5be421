"""Per-vertex attributes a renderer needs from a trimesh mesh: UV + texture image, vertex colours, normals."""
from __future__ import annotations

import warnings

import numpy as np
import trimesh


def mesh_texture(mesh) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``(uv (N, 2) float32 | None, image (H, W, 3) uint8 RGB | None)`` of a trimesh mesh with TextureVisuals.

    ``uv`` follows the OBJ convention (v = 0 at the bottom row of the image).  Meshes without texture
    visuals give ``(None, None)``; a texture-visual mesh whose image is missing warns and gives ``(uv, None)``.
    """
    vis = getattr(mesh, "visual", None)
    if vis is None or getattr(vis, "kind", None) != "texture":
        return None, None
    uv = getattr(vis, "uv", None)
    if uv is None or len(uv) != len(mesh.vertices):
        warnings.warn("mesh has TextureVisuals without per-vertex UV; rendering it grey", stacklevel=2)
        return None, None
    uv = np.asarray(uv, dtype=np.float32)
    mat = getattr(vis, "material", None)
    img = getattr(mat, "image", None) if mat is not None else None
    if img is None:
        # PBR materials keep the texture in baseColorTexture
        img = getattr(mat, "baseColorTexture", None) if mat is not None else None
    if img is None:
        warnings.warn("mesh has UV but no texture image; rendering it grey", stacklevel=2)
        return uv, None
    arr = np.asarray(img.convert("RGB") if hasattr(img, "convert") else img)
    if arr.ndim == 2:
        arr = np.repeat(arr[..., None], 3, axis=-1)
    arr = np.ascontiguousarray(arr[..., :3]).astype(np.uint8, copy=False)
    return uv, arr


def mesh_vertex_colors(mesh) -> np.ndarray | None:
    """(N, 3) float32 RGB in [0, 1] if the mesh has per-vertex (or per-face) colours, else None."""
    vis = getattr(mesh, "visual", None)
    if vis is None or getattr(vis, "kind", None) not in ("vertex", "face"):
        return None
    try:
        vc = np.asarray(vis.vertex_colors)
    except Exception:  # noqa: BLE001 - odd visuals: treat as uncoloured
        return None
    if vc.ndim != 2 or len(vc) != len(mesh.vertices):
        return None
    return (vc[:, :3].astype(np.float32) / 255.0)


def merge_coincident(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge exactly coincident vertices: ``(unique_vertices, faces_on_unique, inverse)`` with
    ``unique_vertices[inverse] == vertices``.  OBJ meshes duplicate vertices at UV seams."""
    V = np.asarray(vertices)
    if len(V) == 0:
        return V, np.asarray(faces, dtype=np.int64), np.zeros(0, dtype=np.int64)
    _, first, inv = np.unique(V, axis=0, return_index=True, return_inverse=True)
    inv = inv.reshape(-1)
    return V[first], inv[np.asarray(faces, dtype=np.int64)], inv


def spatial_order(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reorder a mesh for locality: faces sorted by the Morton (Z-order) code of their centroids, vertices
    renumbered in first-use order (unreferenced vertices dropped).  Same surface, same images; on llvmpipe
    the better vertex-cache and tile locality saves ~20 % of the raster time.

    Returns ``(face_order, vertex_order, faces_new)`` with ``faces_new = remap[faces[face_order]]`` indexing
    ``vertices[vertex_order]``.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    if len(F) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), F.reshape(0, 3)
    c = V[F].mean(axis=1)
    lo, span = c.min(0), np.maximum(np.ptp(c, axis=0), 1e-12)
    q = np.clip(((c - lo) / span * 1023.0).astype(np.int64), 0, 1023)
    code = np.zeros(len(F), dtype=np.int64)
    for b in range(10):
        for a in range(3):
            code |= ((q[:, a] >> b) & 1) << (3 * b + a)
    face_order = np.argsort(code, kind="stable")
    flat = F[face_order].reshape(-1)
    _, first = np.unique(flat, return_index=True)
    vertex_order = flat[np.sort(first)]
    remap = np.full(len(V), -1, dtype=np.int64)
    remap[vertex_order] = np.arange(len(vertex_order))
    return face_order, vertex_order, remap[F[face_order]]


def first_use_order(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Renumber vertices in order of first use by ``faces``: ``(vertices_new, faces_new)``."""
    F = np.asarray(faces, dtype=np.int64)
    flat = F.reshape(-1)
    _, first = np.unique(flat, return_index=True)
    order = flat[np.sort(first)]
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[order] = np.arange(len(order))
    return np.asarray(vertices)[order], remap[F]


def is_closed_outward(vertices: np.ndarray, faces: np.ndarray) -> bool:
    """True if the surface (coincident vertices merged) has no boundary edge, consistent winding and positive
    signed volume, i.e. back faces are never visible from outside and can be culled."""
    Vm, Fm, _ = merge_coincident(vertices, faces)
    if len(Fm) < 4:
        return False
    e = np.sort(np.concatenate([Fm[:, [0, 1]], Fm[:, [1, 2]], Fm[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    if np.any(counts < 2):
        return False
    m = trimesh.Trimesh(Vm, Fm, process=False)
    try:
        return bool(m.is_winding_consistent) and float(m.volume) > 0
    except Exception:  # noqa: BLE001 - odd topology: do not cull
        return False


def smooth_vertex_normals(mesh) -> np.ndarray:
    """(N, 3) float32 unit vertex normals.

    Explicit normals already attached to the mesh are used as they are; otherwise trimesh's area-weighted
    vertex normals are computed on the mesh with coincident vertices merged (OBJ files duplicate vertices at
    UV seams; merging keeps the shading smooth across seams) and mapped back to the original vertices.
    """
    V = np.asarray(mesh.vertices, dtype=np.float64)
    F = np.asarray(mesh.faces, dtype=np.int64)
    if "vertex_normals" in mesh._cache:  # normals given by the file / caller
        n = np.asarray(mesh.vertex_normals, dtype=np.float64)
    elif len(F) == 0:
        n = np.zeros_like(V)
    else:
        Vm, Fm, inv = merge_coincident(V, F)
        merged = trimesh.Trimesh(Vm, Fm, process=False)
        n = np.asarray(merged.vertex_normals, dtype=np.float64)[inv]
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(norm > 1e-12, n / np.maximum(norm, 1e-12), 0.0)
    return n.astype(np.float32)
