"""f_edge with samples moving only across their edges (RefineOptions.edge_across_only,
refine.terms.EdgeTerm.across_only).

Unit tests on an analytic edge image (pixel-area integrated, no renderer): they check the term's
algebra and what it is for (no slide along an edge whose contrast varies), not accuracy on images."""
from __future__ import annotations

import numpy as np

from ycbvss.geometry.se3 import make_T
from ycbvss.refine.edge import edge_field
from ycbvss.refine.problem import BundleProblem, View
from ycbvss.refine.solver import SolverOptions, assemble, run_lm
from ycbvss.refine.terms import EdgeGroup, EdgeTerm, across_edge_directions

K = np.array([[600.0, 0, 160], [0, 600.0, 120], [0, 0, 1]])
Z_MM = 600.0


def _ramp_edge_image(u0_px: float = 160.0, size=(240, 320)) -> np.ndarray:
    """A vertical step edge at u = u0_px (each pixel its area share) whose contrast grows from the
    image's bottom (10 levels) to its top (200 levels)."""
    H, W = size
    u = np.arange(W, dtype=np.float64)
    frac = np.clip(u + 0.5 - u0_px, 0.0, 1.0)[None, :]
    contrast = np.linspace(200.0, 10.0, H)[:, None]
    return np.rint(30.0 + contrast * frac).astype(np.uint8)


def _line_points(n: int = 41) -> np.ndarray:
    """Model points on the vertical segment u = 160 px, v = 60..180 px at Z_MM (the model frame is
    the camera's shifted to Z_MM)."""
    v = np.linspace(60.0, 180.0, n)
    return np.stack([np.zeros(n), (v - 120.0) * Z_MM / 600.0, np.zeros(n)], 1)


def _problem() -> BundleProblem:
    return BundleProblem([View(0, K, 320, 240)], [1], np.eye(4)[None], make_T(np.eye(3), [0, 0, Z_MM])[None],
                         cam_free=np.array([False]))


def test_across_edge_directions_of_a_vertical_edge_point_along_u():
    f = edge_field(_ramp_edge_image(), 1.0)
    from ycbvss.refine.edge import sample_field
    uv = np.stack([np.full(9, 160.0), np.linspace(70, 170, 9)], 1)
    _, _, H, _ = sample_field(f, uv)
    n = across_edge_directions(H)
    assert np.all(np.abs(np.abs(n[:, 0]) - 1.0) < 1e-3), n


def test_across_only_gradient_matches_finite_differences_of_its_cost(fd_gradient):
    f = edge_field(_ramp_edge_image(), 1.0)
    pb = _problem()
    pb.T_m[0] = pb.T_m[0] @ make_T(np.eye(3), [0.4, 1.0, 0.0])
    term = EdgeTerm([f], [EdgeGroup(0, 0, _line_points())], across_only=True)
    _, lins = term.linearize(pb)
    _, g = assemble(pb.n_blocks, lins)
    g_fd = fd_gradient(pb, term, 1e-4)
    rel = float(np.linalg.norm(g - g_fd) / np.linalg.norm(g_fd))
    assert rel < 0.05, rel


def _refined_slide_mm(across: bool) -> tuple[float, float]:
    """Refine the segment from its exact pose on the ramp edge; returns (|x| off the edge, |y| slid
    along it) in mm at Z_MM (1 px = 1 mm)."""
    f = edge_field(_ramp_edge_image(), 1.0)
    pb = _problem()
    term = EdgeTerm([f], [EdgeGroup(0, 0, _line_points())], across_only=across)
    run_lm(pb, [term], SolverOptions(max_iters=30))
    t = pb.T_m[0][:3, 3]
    return abs(float(t[0])), abs(float(t[1]))


def test_a_segment_on_an_edge_of_varying_contrast_does_not_slide_along_it():
    x_plain, y_plain = _refined_slide_mm(False)
    x_across, y_across = _refined_slide_mm(True)
    assert y_plain > 1.0, y_plain              # E-sum: the samples slide towards the stronger contrast
    assert y_across < 0.05, y_across           # across only: nothing pulls along the edge
    assert x_across < 0.05, x_across           # and the segment stays on the edge
