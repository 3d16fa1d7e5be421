"""The refiner's mesh cache never draws one model with another's mesh.

Keys of the fast renderer's meshes hold ``id(model)``; CPython reuses the address of a freed object,
so a later model (a second procedural scene in the same process, same obj_id) can get the same key.
The renderer keeps the owner of each key and re-uploads for a different owner. Under the old cache
the status tests failed in one full CI run only (order- and memory-dependent: a 20 deg scene drawn
with the previous scene's meshes, 22 mm errors)."""
from __future__ import annotations

import numpy as np
import trimesh

from ycbvss.refine import templates


class _Model:
    def __init__(self, mesh):
        self.mesh = mesh
        self.path = None


def _depth_centre(r, key) -> float:
    K = np.array([[500.0, 0, 64], [0, 500.0, 48], [0, 0, 1]])
    T = np.eye(4)
    T[2, 3] = 500.0
    d = r.render(K, 128, 96, [(key, T)], outputs=("depth",)).depth_mm
    return float(d[48, 64])


def test_same_key_for_another_model_is_uploaded_anew(monkeypatch):
    r = templates.get_renderer()
    small = _Model(trimesh.creation.box((20.0, 20.0, 20.0)))     # front face at z = 500 - 10
    big = _Model(trimesh.creation.box((60.0, 60.0, 60.0)))       # front face at z = 500 - 30
    # what id() reuse produces: the same key for two different model objects
    monkeypatch.setattr(templates, "mesh_key", lambda oid, m: ("test_mesh_cache", int(oid)))
    templates.ensure_meshes(r, {1: small})
    assert abs(_depth_centre(r, ("test_mesh_cache", 1)) - 490.0) < 0.5
    templates.ensure_meshes(r, {1: big})
    assert abs(_depth_centre(r, ("test_mesh_cache", 1)) - 470.0) < 0.5
    assert r.has_mesh_of(("test_mesh_cache", 1), big) and not r.has_mesh_of(("test_mesh_cache", 1), small)
    r.remove_mesh(("test_mesh_cache", 1))
    assert not r.has_mesh(("test_mesh_cache", 1))
