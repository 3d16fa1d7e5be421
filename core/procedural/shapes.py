"""Procedural object meshes (trimesh, millimetres) with per-vertex UVs into a texture atlas.

All meshes are centred on their bounding-box centre (the BOP model convention) with the
symmetry / up axis along model +z. Faces are "unmerged" (3 vertices per face) so that UVs
can be discontinuous at chart borders, as in BOP model files with UV seams.

UV atlas layout (u right, v up, OpenGL/PLY convention): boxes use a 3 x 2 grid of cells
(one per face direction); solids of revolution put the lateral surface on the top 3/4 and the
flat (cap) faces on the bottom 1/4.
"""
from __future__ import annotations

import numpy as np
import trimesh
from PIL import Image

_MARGIN = 0.01


def _cell(uv01: np.ndarray, cell_u: np.ndarray, cell_v: np.ndarray, n_u: int, n_v: int,
          v0: float = 0.0, v1: float = 1.0) -> np.ndarray:
    """Map chart coordinates in [0,1]^2 into atlas cell (cell_u, cell_v) of an n_u x n_v grid
    spanning atlas v in [v0, v1]."""
    w, h = 1.0 / n_u, (v1 - v0) / n_v
    u = (cell_u + _MARGIN + (1 - 2 * _MARGIN) * uv01[..., 0]) * w
    v = v0 + (cell_v + _MARGIN + (1 - 2 * _MARGIN) * uv01[..., 1]) * h
    return np.stack([u, v], -1)


def _textured(vertices_per_face: np.ndarray, uv_per_face: np.ndarray, texture_rgb: np.ndarray,
              normals_per_face: np.ndarray | None = None):
    """Build an unmerged Trimesh (F*3 vertices) with TextureVisuals from (F,3,3) and (F,3,2);
    ``normals_per_face`` (F,3,3) become explicit vertex normals (sharp edges stay sharp)."""
    F = vertices_per_face.shape[0]
    v = vertices_per_face.reshape(-1, 3)
    uv = np.clip(uv_per_face.reshape(-1, 2), 0.0, 1.0)
    faces = np.arange(F * 3, dtype=np.int64).reshape(F, 3)
    material = trimesh.visual.material.SimpleMaterial(image=Image.fromarray(texture_rgb))
    visual = trimesh.visual.TextureVisuals(uv=uv, image=None, material=material)
    mesh = trimesh.Trimesh(vertices=v, faces=faces, visual=visual, process=False)
    if normals_per_face is not None:
        n = normals_per_face.reshape(-1, 3)
        mesh.vertex_normals = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    return mesh


def _revolution_normals(tri: np.ndarray, face_normals: np.ndarray) -> np.ndarray:
    """Vertex normals of a solid of revolution about z: radial (smooth) on lateral faces, the face
    normal on flat faces (|n_z| > 0.9)."""
    radial = np.concatenate([tri[..., :2], np.zeros(tri.shape[:2] + (1,))], -1)
    radial /= np.maximum(np.linalg.norm(radial, axis=-1, keepdims=True), 1e-12)
    sgn = np.sign(np.einsum("fvk,fk->fv", radial, face_normals))[..., None]
    radial = radial * np.where(sgn == 0, 1.0, sgn)
    flat = np.abs(face_normals[:, 2]) > 0.9
    out = np.where(flat[:, None, None], face_normals[:, None, :], radial)
    return out


def _subdivided(mesh: trimesh.Trimesh, max_edge_mm: float) -> trimesh.Trimesh:
    """Split long edges so the model has dense vertices (the metric points) and small faces."""
    v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=max_edge_mm)
    return trimesh.Trimesh(v, f, process=False)


def _centre(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    lo, hi = mesh.bounds
    mesh.apply_translation(-(lo + hi) / 2.0)
    return mesh


def box(size_mm: tuple[float, float, float], texture_rgb: np.ndarray) -> trimesh.Trimesh:
    """A box of extents (x, y, z) in mm centred at the origin; each face direction gets its own
    cell of a 3 x 2 atlas so no two faces show the same texture patch."""
    base = _subdivided(trimesh.creation.box(extents=size_mm), 20.0)
    tri = base.vertices[base.faces]                       # (F, 3, 3)
    n = base.face_normals
    ax = np.argmax(np.abs(n), axis=1)
    sgn = (n[np.arange(len(n)), ax] > 0).astype(int)
    ext = np.asarray(size_mm, np.float64)
    other = np.array([[1, 2], [0, 2], [0, 1]])[ax]        # in-plane axes per face
    a = np.take_along_axis(tri, other[:, None, :].repeat(3, 1), axis=2)   # (F, 3, 2)
    e = ext[other][:, None, :]
    uv01 = a / e + 0.5
    uv = _cell(uv01, (ax % 3).astype(float)[:, None] * np.ones((1, 3)),
               sgn.astype(float)[:, None] * np.ones((1, 3)), 3, 2)
    return _centre(_textured(tri, uv, texture_rgb, np.repeat(base.face_normals[:, None, :], 3, 1)))


def _revolution_uv(tri: np.ndarray, normals: np.ndarray, radius: float, z_lo: float, z_hi: float) -> np.ndarray:
    """UVs for a solid of revolution about z: lateral faces cylindrically (top 3/4 of the atlas),
    flat faces (|n_z| > 0.9) planar in the bottom 1/4 (left half: facing down, right: up)."""
    F = tri.shape[0]
    uv = np.zeros((F, 3, 2))
    flat = np.abs(normals[:, 2]) > 0.9
    # lateral: u = azimuth, v = height
    ang = (np.arctan2(tri[..., 1], tri[..., 0]) + np.pi) / (2 * np.pi)      # (F, 3) in [0, 1]
    span = ang.max(1) - ang.min(1)
    wrap = span > 0.5
    ang = np.where(wrap[:, None] & (ang > 0.5), ang - 1.0, ang)
    ang = np.clip(ang, 0.0, 1.0)
    hz = (tri[..., 2] - z_lo) / max(z_hi - z_lo, 1e-9)
    lat = np.stack([ang, hz], -1)
    lat_uv = np.stack([_MARGIN + (1 - 2 * _MARGIN) * lat[..., 0],
                       0.25 + _MARGIN + (0.75 - 2 * _MARGIN) * lat[..., 1]], -1)
    # flat: planar projection x, y
    pl = np.stack([tri[..., 0], tri[..., 1]], -1) / (2 * radius) + 0.5
    up = (normals[:, 2] > 0).astype(float)[:, None] * np.ones((1, 3))
    flat_uv = _cell(pl, up, np.zeros_like(up), 2, 1, 0.0, 0.25)
    uv[~flat] = lat_uv[~flat]
    uv[flat] = flat_uv[flat]
    return uv


def cylinder(radius_mm: float, height_mm: float, texture_rgb: np.ndarray, sections: int = 64) -> trimesh.Trimesh:
    """A closed cylinder about model z, centred at the origin."""
    base = _subdivided(trimesh.creation.cylinder(radius=radius_mm, height=height_mm, sections=sections), 20.0)
    tri = base.vertices[base.faces]
    uv = _revolution_uv(tri, base.face_normals, radius_mm, -height_mm / 2, height_mm / 2)
    return _centre(_textured(tri, uv, texture_rgb, _revolution_normals(tri, base.face_normals)))


def mug(radius_mm: float, height_mm: float, wall_mm: float, texture_rgb: np.ndarray,
        handle_major_mm: float = 24.0, handle_minor_mm: float = 6.0, sections: int = 64) -> trimesh.Trimesh:
    """A mug-like shape: a revolved cup (outer wall, rim, inner wall, thick bottom) plus a handle
    (a torus in the model xz-plane whose part inside the wall is cut away). The cup is a closed
    surface; the handle's cut ends are hidden inside the wall, so it renders as a solid."""
    R, H, w = float(radius_mm), float(height_mm), float(wall_mm)
    bottom = max(w, 6.0)
    profile = [[0, 0], [R, 0], [R, H], [R - w, H], [R - w, bottom], [0, bottom]]
    cup = _subdivided(trimesh.creation.revolve(profile, sections=sections), 20.0)
    rot = trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0])
    rot[:3, 3] = [R + handle_major_mm - 2.5 * handle_minor_mm, 0.0, H * 0.55]
    tor = trimesh.creation.torus(handle_major_mm, handle_minor_mm, major_sections=40, minor_sections=16,
                                 transform=rot)
    keep = tor.triangles_center[:, 0] > R - w / 2
    tor = trimesh.Trimesh(tor.vertices, tor.faces[keep], vertex_normals=tor.vertex_normals, process=False)
    tri = np.concatenate([cup.vertices[cup.faces], tor.vertices[tor.faces]], 0)
    normals = np.concatenate([cup.face_normals, tor.face_normals], 0)
    uv = _revolution_uv(tri, normals, R + handle_major_mm, 0.0, H)
    vn = np.concatenate([_revolution_normals(cup.vertices[cup.faces], cup.face_normals),
                         tor.vertex_normals[tor.faces]], 0)
    return _centre(_textured(tri, uv, texture_rgb, vn))


def table(size_mm: float, texture_rgb: np.ndarray, repeats: float = 1.0) -> trimesh.Trimesh:
    """A square table top (two triangles, normal +z) of side ``size_mm`` at z = 0, centred at the origin."""
    s = size_mm / 2.0
    tri = np.array([[[-s, -s, 0], [s, -s, 0], [s, s, 0]], [[-s, -s, 0], [s, s, 0], [-s, s, 0]]], np.float64)
    uv = (tri[..., :2] / size_mm + 0.5) * repeats
    material = trimesh.visual.material.SimpleMaterial(image=Image.fromarray(texture_rgb))
    visual = trimesh.visual.TextureVisuals(uv=uv.reshape(-1, 2), material=material)
    return trimesh.Trimesh(tri.reshape(-1, 3), np.arange(6).reshape(2, 3), visual=visual, process=False)
