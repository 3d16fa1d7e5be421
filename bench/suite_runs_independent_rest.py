"""``bench/suite_runs.py`` with the resting faces of ``RefineOptions.table_rest`` taken from an
independent model of each object: the official YCB-Video ``points.xyz`` (its convex hull), not the
scanned mesh the suite's scenes were generated and rendered with.

Why: the suite's generator sets every object on a stable face of exactly the mesh the refiner
uses (:func:`ycbvss.procedural.ycbv_scene.rest_poses`), so a resting-face prior built from that
mesh is exact there, which no real scene gives. The official models lie about 1 mm from the scans
(``../shared/data/SOURCES.md``): the same size of disagreement as between a model and the real
object, so this run measures what the prior is worth on a real table. Arguments as
``bench/suite_runs.py``; the dataset must be a YCB-Video root (``models/<name>/points.xyz``).

    python bench/suite_runs_independent_rest.py run --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --kinds short --seeds 0 --work /tmp/runs/rest_indep --options '{"table_rest": "narrow,medium"}'
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    import suite_runs

    from ycbvss.io.ycbv import load_ycbv_models, model_center_mm
    from ycbvss.refine import table_rest

    argv = list(sys.argv[1:] if argv is None else argv)
    dataset = Path(argv[argv.index("--dataset") + 1])
    ycbv = load_ycbv_models(dataset)
    points = {}                                   # BOP-frame points (mm) by object name
    for oid, m in ycbv.items():
        p = Path(m.info["points_xyz"])
        if p.is_file():
            points[m.name] = np.loadtxt(p, dtype=np.float64) * 1000.0 - model_center_mm(m.path)
    own = table_rest.model_rest_faces
    cache: dict = {}

    def independent(mesh, acc_mm: float = 1.0):
        """The resting faces of the official points of the object whose cloud best matches ``mesh``'s
        bounds (the scan and the official model share the YCB-V frame, to about a millimetre)."""
        b = np.asarray(mesh.bounds, np.float64)
        key = (tuple(np.round(b.ravel(), 3)), acc_mm)
        if key not in cache:
            name = min(points, key=lambda n: float(np.abs(np.r_[points[n].min(0), points[n].max(0)] - b.ravel()).max()))
            gap = float(np.abs(np.r_[points[name].min(0), points[name].max(0)] - b.ravel()).max())
            if gap > 10.0:                         # no official model of this mesh: its own faces
                cache[key] = own(mesh, acc_mm)
            else:
                cache[key] = table_rest.rest_faces(points[name], acc_mm)
            print(f"table_rest faces of {name if gap <= 10.0 else 'own mesh'} (bounds within {gap:.1f} mm)", flush=True)
        return cache[key]

    table_rest.model_rest_faces = independent
    return suite_runs.main(argv)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    sys.exit(main())
