"""refine.openness: the share of the sky a model's surface point sees."""
import numpy as np
import pytest
import trimesh

from ycbvss.refine.openness import open_points, openness_at, sphere_directions, vertex_openness


def _tube(r_in_mm: float = 10.0, r_out_mm: float = 14.0, h_mm: float = 100.0) -> trimesh.Trimesh:
    ring = trimesh.creation.annulus(r_min=r_in_mm, r_max=r_out_mm, height=h_mm, sections=48)
    V, F = trimesh.remesh.subdivide_to_size(ring.vertices, ring.faces, max_edge=4.0)
    return trimesh.Trimesh(V, F)      # vertices along the walls, not only at the two ends


def test_directions_cover_the_sphere_evenly():
    D = sphere_directions(256)
    assert np.allclose(np.linalg.norm(D, axis=1), 1.0)
    assert np.linalg.norm(D.mean(axis=0)) < 0.01          # no side preferred
    for axis in np.eye(3):
        assert abs(np.mean(D @ axis > 0) - 0.5) < 0.02    # half of them on each side of any plane


def test_convex_surface_sees_the_whole_sky():
    op = vertex_openness(trimesh.creation.icosphere(subdivisions=3, radius=50.0))
    assert op.min() > 0.99


def test_inside_of_a_tube_sees_little_sky():
    tube = _tube()
    V = tube.vertices
    r = np.linalg.norm(V[:, :2], axis=1)
    middle = np.abs(V[:, 2]) < 20.0
    op = vertex_openness(tube, n_dirs=128)
    # the outer wall is convex in the plane and open above and below: all of its sky
    assert np.median(op[(r > 13.0) & middle]) > 0.95
    # from the middle of a 100 mm tube of 20 mm bore the two ends subtend a few percent of the sky
    assert np.median(op[(r < 11.0) & middle]) < 0.2


def test_flipped_normals_and_nearby_shreds_change_nothing():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=50.0)
    flipped = sphere.copy()
    flipped.invert()                                       # inward normals: the other side is tried as well
    assert vertex_openness(flipped).min() > 0.99
    # a second shell 1 mm inside the first (a scan's overlapping shreds) is nearer than skip_mm
    shells = trimesh.util.concatenate([sphere, trimesh.creation.icosphere(subdivisions=3, radius=49.0)])
    op = vertex_openness(shells)[: len(sphere.vertices)]
    assert op.min() > 0.99


def test_openness_at_reads_the_nearest_vertex_and_caches_per_mesh():
    tube = _tube()
    X = np.array([[0.0, 10.0, 0.0], [0.0, 14.0, 0.0]])   # on the inner and on the outer wall
    a = openness_at(tube, X)
    assert a[0] < 0.2 < 0.95 < a[1]
    assert openness_at(tube, np.zeros((0, 3))).shape == (0,)
    with pytest.raises(ValueError):
        openness_at(tube, np.zeros((2, 2)))


def test_open_points_keeps_what_sees_enough_sky():
    tube = _tube()
    X = np.array([[0.0, 10.0, 0.0], [0.0, 14.0, 0.0], [14.0, 0.0, 10.0]])
    assert open_points(tube, X, 0.5).tolist() == [False, True, True]
    assert open_points(tube, X, 0.0).all()                 # off: every point


def test_repeated_corners_are_cast_once_with_the_same_result():
    """A flat-shaded mesh repeats each corner per face: the rays are cast once per distinct
    (position, normal), and every copy gets exactly what casting them per vertex gives."""
    from ycbvss.refine.openness import _openness
    tube = _tube()
    flat = trimesh.Trimesh(tube.vertices[tube.faces].reshape(-1, 3), np.arange(3 * len(tube.faces)).reshape(-1, 3),
                           process=False)
    V, N = np.asarray(flat.vertices), np.asarray(flat.vertex_normals)
    assert len(np.unique(np.hstack([V, N]), axis=0)) < 0.9 * len(V)     # copies with equal normals are there
    assert np.array_equal(vertex_openness(flat), _openness(flat, V, N, 64, 3.0))
