"""Bundle pose refinement of all objects and cameras of a static multi-object sequence.

Model: world frame = first camera; P_ij = T_c[i] @ T_m[j]. Cost
f = f_edge + alpha f_point + beta f_t (paper Sec. 3), solved by damped Newton / Levenberg-Marquardt
on left se(3) increments of all cameras (the first fixed) and objects, with sparse normal
equations, after a CosyPose-style scene-consistent initialisation.

    from ycbvss.refine import RefineOptions, refine_scene, RefineResult
    res = refine_scene(scene, models, init, options=RefineOptions(), images=None)
"""
from .bundle import refine_scene
from .options import RefineOptions, RefineResult

__all__ = ["RefineOptions", "RefineResult", "refine_scene"]
