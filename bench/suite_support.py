"""How far each refined object of suite rows is from resting on anything (refine.support), from the rows alone.

    python bench/suite_support.py --suite-root /tmp/suite/full --rows ROWS.csv.gz [...] --out DIR

The rows hold each pose's error against the exact GT (``dx/dy/dz_mm`` in the camera frame,
``rx/ry/rz_obj_deg`` in the model frame), so the refined poses of a clip's first view are the GT's
(``scene_gt.json`` under ``--suite-root/test``) with those errors applied. At those poses, per
(clip, seed, object): the height of the object's lowest hull vertex above the table plane
(:func:`ycbvss.refine.support.table_plane`), the gap to the nearest other object and
``unsupported_mm`` = min of the two, with the object's mean ADD and statuses. A status check on that
quantity (``refine.confidence.UNSUPPORTED_MM``) can so be judged on rows refined before it existed.
Writes ``support_rows.csv`` (every record) and ``support.md/.csv/.tex`` (per clip kind: records, the
largest ``unsupported_mm`` of an object within ADD 2 mm, records above the threshold and their
ADD > 10 mm count) into ``--out``.
"""
from __future__ import annotations

import argparse
import csv
import gzip
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from ycbvss.eval.tables import Row, Table, write_table
from ycbvss.geometry.so3 import exp_so3
from ycbvss.pipeline.suite import suite_models
from ycbvss.refine.confidence import UNSUPPORTED_MM
from ycbvss.refine.contact import contact_surface
from ycbvss.refine.support import unsupported_mm


def _rows(paths: list[str]) -> list[dict]:
    out = []
    for n, p in enumerate(paths):
        op = gzip.open if p.endswith(".gz") else open
        with op(p, "rt", newline="") as fh:
            out += [{**r, "_file": n} for r in csv.DictReader(fh) if r.get("init", "paper") == "paper"
                    and r.get("variant", "using all") == "using all"]
    return out


def _gt(root: Path, sid: int) -> dict:
    return json.loads((root / "test" / f"{sid:06d}" / "scene_gt.json").read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--dataset", default="../shared/data/ycbv")
    ap.add_argument("--rows", nargs="+", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    root, out = Path(a.suite_root), Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = [r for r in _rows(a.rows) if (root / "test" / f"{int(r['scene_id']):06d}" / "scene_gt.json").is_file()]
    groups = defaultdict(list)
    for r in rows:
        groups[(r["_file"], r["clip"], int(r["seed"]))].append(r)
    objs = sorted({int(r["obj_id"]) for r in rows})
    models = suite_models(a.dataset, root, objs)
    hull = {o: np.asarray(models[o].mesh.convex_hull.vertices, float) for o in objs}
    surf = {o: contact_surface(models[o].mesh) for o in objs}
    gts: dict = {}
    recs = []
    for (_, clip, seed), g in sorted(groups.items()):
        sid = int(g[0]["scene_id"])
        gt = gts.setdefault(sid, _gt(root, sid))
        im = min(int(r["im_id"]) for r in g)
        ids, T = [], []
        for r in (r for r in g if int(r["im_id"]) == im):
            e = next(x for x in gt[str(im)] if int(x["obj_id"]) == int(r["obj_id"]))
            P = np.eye(4)
            P[:3, :3] = np.reshape(e["cam_R_m2c"], (3, 3)) @ exp_so3(np.radians(
                [float(r["rx_obj_deg"]), float(r["ry_obj_deg"]), float(r["rz_obj_deg"])]))
            P[:3, 3] = np.asarray(e["cam_t_m2c"], float) + [float(r["dx_mm"]), float(r["dy_mm"]), float(r["dz_mm"])]
            ids.append(int(r["obj_id"]))
            T.append(P)
        res = unsupported_mm(np.stack(T), [hull[o] for o in ids], [surf[o] for o in ids], np.zeros((1, 3)),
                             list(range(len(ids))))
        for k, o in enumerate(ids):
            mine = [r for r in g if int(r["obj_id"]) == o]
            recs.append({"clip": clip, "kind": g[0]["kind"], "seed": seed, "obj_id": o,
                         "height_mm": res[k]["height_mm"], "gap_mm": res[k]["gap_mm"],
                         "unsupported_mm": res[k]["unsupported_mm"],
                         "add_mm": float(np.mean([float(r["add_mm"]) for r in mine])),
                         "statuses": "".join(sorted({r["status"][0] for r in mine}))})
    with open(out / "support_rows.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(recs[0]))
        w.writeheader()
        w.writerows(recs)
    t = Table(columns=["records", "max unsupported, ADD <= 2 mm (mm)", f"> {UNSUPPORTED_MM:g} mm",
                       "of those ADD > 10 mm", "ADD > 10 mm, not above"], label_header="clips", digits=2)
    for kind in ("short", "medium", "long"):
        rk = [r for r in recs if r["kind"] == kind and np.isfinite(r["unsupported_mm"])]
        if not rk:
            continue
        good = [r["unsupported_mm"] for r in rk if r["add_mm"] <= 2.0]
        above = [r for r in rk if r["unsupported_mm"] > UNSUPPORTED_MM]
        t.rows.append(Row(kind, [len(rk), max(good) if good else None, len(above),
                                 sum(r["add_mm"] > 10 for r in above),
                                 sum(r["add_mm"] > 10 and r["unsupported_mm"] <= UNSUPPORTED_MM for r in rk)]))
    t.caption = ("Per (clip, seed, object), at each clip's first view: how far the refined object is from the table "
                 "and every other object (refine.support)")
    for p in write_table(t, out, "support"):
        print(p)


if __name__ == "__main__":
    main()
