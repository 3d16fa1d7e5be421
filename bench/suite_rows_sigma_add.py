"""Add the ``sigma_add_mm`` column to suite rows written before it existed (session 78), so that the
report applies today's sigma rule to them (:func:`ycbvss.pipeline.suite_report.row_sigmas`).

The column is what the refiner records: the ADD (mm) of a 1-sigma error of the pose's statistical
part, :func:`ycbvss.refine.confidence.sigma_add_mm` of the row's covariance sigmas times its
baseline group's calibration factors, the rotation acting at the model's mean vertex distance from
its origin. Poses and every other column are copied unchanged. Checked against a fresh run
(short-1, seed 0): the recomputed column equals the refiner's to the last bit.

    python bench/suite_rows_sigma_add.py --models /tmp/suite/full/models \\
        --rows bench/results/ycbv21/s76/rows/s76_long2_sm.csv.gz --out /tmp/s76_long2_sm_sa.csv.gz
"""
from __future__ import annotations

import argparse
import csv
import gzip
import io
from pathlib import Path

import numpy as np


def model_radius_mm(models_dir: Path, obj_id: int) -> float:
    """Mean vertex distance (mm) from the model origin of ``obj_<id>.ply``, as the refiner's quality record."""
    import trimesh

    mesh = trimesh.load(models_dir / f"obj_{obj_id:06d}.ply", process=False)
    return float(np.linalg.norm(np.asarray(mesh.vertices, np.float64), axis=1).mean())


def main() -> None:
    from ycbvss.io.atomic import write_bytes_atomic
    from ycbvss.pipeline.suite_report import KIND_GROUP, SIGMA_AXES
    from ycbvss.refine.confidence import sigma_add_mm, sigma_scale

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", required=True, help="the suite's models folder (obj_XXXXXX.ply, mm)")
    ap.add_argument("--rows", required=True, help="rows.csv(.gz) of bench/suite_runs.py")
    ap.add_argument("--out", required=True, help="rows file to write (.csv or .csv.gz)")
    a = ap.parse_args()
    src = Path(a.rows)
    with (gzip.open if src.suffix == ".gz" else open)(src, "rt", newline="") as fh:
        rd = csv.DictReader(fh)
        fields = list(rd.fieldnames or [])
        rows = list(rd)
    if "sigma_add_mm" not in fields:
        fields.append("sigma_add_mm")
    radius: dict[int, float] = {}
    for r in rows:
        oid = int(r["obj_id"])
        if oid not in radius:
            radius[oid] = model_radius_mm(Path(a.models), oid)
        f = np.asarray(sigma_scale(KIND_GROUP[r["kind"]]), float)
        raw = np.array([float(r[s]) if r[s] != "" else np.nan for _, s in SIGMA_AXES], float)
        stat = f * raw
        r["sigma_add_mm"] = repr(sigma_add_mm(stat[:3], stat[3], radius[oid])) if np.all(np.isfinite(stat)) else ""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    data = buf.getvalue().encode()
    out = Path(a.out)
    write_bytes_atomic(out, gzip.compress(data, mtime=0) if out.suffix == ".gz" else data)
    print(f"{out}: {len(rows)} rows, sigma_add_mm for {sum(r['sigma_add_mm'] != '' for r in rows)}")


if __name__ == "__main__":
    main()
