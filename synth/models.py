"""YCBV-SS models: input models recentred on their bounding-box centre (BOP convention) and
enlarged by a per-object scale about that centre; poses re-expressed in the recentred frame.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from ..io.bop import write_models
from ..io.mesh import load_geometry_mm


def transform_symmetries(disc: list, cont: list, c_mm: np.ndarray, scale: float) -> tuple[list, list]:
    """Symmetries of the input model frame -> recentred (by c) and scaled (by s) frame."""
    c = np.asarray(c_mm, np.float64)
    out_d = []
    for S in disc:
        S = np.asarray(S, np.float64).reshape(4, 4)
        T = S.copy()
        T[:3, 3] = (S[:3, :3] @ c + S[:3, 3] - c) * scale
        out_d.append(T)
    out_c = [{"axis": [float(a) for a in s["axis"]],
              "offset": ((np.asarray(s.get("offset", (0, 0, 0)), np.float64) - c) * scale).tolist()} for s in cont]
    return out_d, out_c


def centred_mesh(model, c_mm: np.ndarray, scale: float = 1.0):
    """A copy of ``model.mesh`` (mm) moved by -c and scaled by ``scale`` about the origin; texture kept."""
    m = model.mesh.copy()
    m.vertices = (np.asarray(m.vertices, np.float64) - np.asarray(c_mm, np.float64)) * float(scale)
    return m


def write_dilated_models(models_dir: str | Path, models: dict, centres: dict, scales: dict) -> dict:
    """Write obj_XXXXXX.ply (+ .png texture) and models_info.json of the enlarged models."""
    meshes, syms = {}, {}
    for oid in sorted(scales):
        m = models[oid]
        meshes[oid] = centred_mesh(m, centres[oid], scales[oid])
        syms[oid] = transform_symmetries(m.symmetries_discrete, m.symmetries_continuous, centres[oid], scales[oid])
    return write_models(models_dir, meshes, symmetries=syms)


def write_original_models(models_dir: str | Path, models: dict, centres: dict) -> dict:
    """models_original/: the input models recentred (same frame as models/), NOT enlarged, geometry only."""
    meshes, syms = {}, {}
    for oid in sorted(centres):
        m = models[oid]
        g = load_geometry_mm(m.path, m.unit_scale) if m.path is not None else m.mesh
        meshes[oid] = trimesh.Trimesh(np.asarray(g.vertices, np.float64) - np.asarray(centres[oid], np.float64),
                                      np.asarray(g.faces), process=False)
        syms[oid] = transform_symmetries(m.symmetries_discrete, m.symmetries_continuous, centres[oid], 1.0)
    return write_models(models_dir, meshes, symmetries=syms)
