"""Mesh I/O: the real BOP ycbv model files, PLY round trip, models_info, missing textures.

Budget: ~3 s.
"""
from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest

from ycbvss.errors import YcbvssError
from ycbvss.io.mesh import (compute_models_info, diameter_mm, load_mesh_mm, load_vertices_mm,
                            vertex_normals_across_seams, write_ply_mm)


@pytest.mark.parametrize("obj_id, n_vertices, official_diameter", [(1, 9951, 172.063), (2, 8291, 269.573)])
def test_real_bop_ply_loads_with_stored_vertices_and_mm_diameter(bop_models_root, obj_id, n_vertices,
                                                                 official_diameter):
    path = bop_models_root / "models" / f"obj_{obj_id:06d}.ply"
    v = load_vertices_mm(path)          # obj_000001 is ASCII, obj_000002 binary
    assert v.shape == (n_vertices, 3)
    d = diameter_mm(v)
    # BOP models_info diameters (172.063 for obj 1 from the BOP ycbv release, 269.573 shipped for obj 2)
    assert abs(d - official_diameter) < 0.01, d
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        mesh = load_mesh_mm(path)       # the texture PNG is not shipped -> one warning, grey
    assert len(mesh.vertices) == n_vertices
    assert any("texture" in str(x.message) and "missing" in str(x.message) for x in w)
    assert np.abs(np.asarray(mesh.vertices) - v).max() < 1e-4


def test_models_info_of_real_obj2_matches_official(bop_models_root):
    import json
    official = json.loads((bop_models_root / "models" / "models_info.json").read_text())["2"]
    info = compute_models_info(load_vertices_mm(bop_models_root / "models" / "obj_000002.ply"))
    for k in ("diameter", "min_x", "min_y", "min_z", "size_x", "size_y", "size_z"):
        assert abs(info[k] - official[k]) < 1e-3, (k, info[k], official[k])


def test_write_ply_round_trip_keeps_vertices_uv_and_texture(ycbv_root, tmp_path):
    src = ycbv_root / "models" / "061_foam_brick" / "textured.obj"
    mesh = load_mesh_mm(src, 1000.0)
    n_obj_v = len(load_vertices_mm(src))
    assert len(mesh.vertices) > n_obj_v          # UV seams duplicate vertices (trimesh, process=False)
    import cv2
    tex = cv2.resize(np.asarray(mesh.visual.material.image.convert("RGB")), (512, 512), interpolation=cv2.INTER_AREA)
    write_ply_mm(tmp_path / "obj_000021.ply", mesh, "obj_000021.png", texture_rgb=tex)
    back = load_mesh_mm(tmp_path / "obj_000021.ply")
    assert len(back.vertices) == len(mesh.vertices) and len(back.faces) == len(mesh.faces)
    assert np.abs(np.asarray(back.vertices) - mesh.vertices).max() < 1e-3      # float32 in mm
    assert np.abs(np.asarray(back.visual.uv) - mesh.visual.uv).max() < 1e-6
    back_tex = np.asarray(back.visual.material.image.convert("RGB"))
    assert back_tex.shape == (512, 512, 3) and np.abs(back_tex.astype(int) - tex).max() == 0   # lossless PNG
    hdr = (tmp_path / "obj_000021.ply").read_bytes()[:400].decode("latin-1")
    assert "comment TextureFile obj_000021.png" in hdr and "binary_little_endian" in hdr
    assert load_vertices_mm(tmp_path / "obj_000021.ply").shape == (len(mesh.vertices), 3)


def test_seam_normals_are_shared_by_duplicates():
    # a unit cube split into two vertex copies per corner: copies must get the same normal
    import trimesh
    box = trimesh.creation.box()
    v = np.vstack([box.vertices, box.vertices])
    f = np.vstack([box.faces[:6], box.faces[6:] + len(box.vertices)])
    n = vertex_normals_across_seams(v, f)
    assert np.abs(n[: len(box.vertices)] - n[len(box.vertices):]).max() < 1e-12
    assert np.abs(np.linalg.norm(n, axis=1) - 1).max() < 1e-12


def test_truncated_ply_and_missing_file_raise_named_errors(bop_models_root, tmp_path):
    data = (bop_models_root / "models" / "obj_000002.ply").read_bytes()
    bad = tmp_path / "obj_000002.ply"
    bad.write_bytes(data[: len(data) // 3])
    with pytest.raises(YcbvssError, match="obj_000002.ply.*truncated"):
        load_vertices_mm(bad)
    with pytest.raises(YcbvssError, match="obj_000099.ply: missing model file"):
        load_vertices_mm(tmp_path / "obj_000099.ply")


def test_obj_with_missing_texture_warns_and_is_grey(ycbv_root, tmp_path):
    d = ycbv_root / "models" / "061_foam_brick"
    shutil.copy(d / "textured.obj", tmp_path)
    shutil.copy(d / "textured.mtl", tmp_path)       # texture_map.jpg not copied
    with pytest.warns(UserWarning, match="texture_map.jpg missing"):
        m = load_mesh_mm(tmp_path / "textured.obj", 1000.0)
    cols = np.asarray(m.visual.vertex_colors)
    assert np.all(cols[:, :3] == 153)


def test_vertex_coloured_mesh_round_trip(tmp_path):
    import trimesh
    box = trimesh.creation.box(extents=(10, 20, 30))
    box.visual.vertex_colors = np.tile([200, 10, 30, 255], (len(box.vertices), 1))
    write_ply_mm(tmp_path / "obj_000001.ply", box, "obj_000001.png")     # no UVs: colours, no texture
    back = load_mesh_mm(tmp_path / "obj_000001.ply")
    assert back.visual.kind == "vertex" and np.all(back.visual.vertex_colors[:, :3] == [200, 10, 30])
    assert not (tmp_path / "obj_000001.png").exists()
    assert abs(compute_models_info(back)["diameter"] - np.sqrt(10**2 + 20**2 + 30**2)) < 1e-4
