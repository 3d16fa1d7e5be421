"""Where f_edge's minimum lies from the exact GT, per sample class: one Newton step for one object.

At the exact GT the edge cost should be flat. For one object of a suite clip this bench takes, in
every frame of the clip, the object's f_edge candidates as a narrow bundle's finest level takes
them (contour samples matched to the 1 px blur, T-junction samples dropped, interior texture
samples sharper than ``--sharp``, the normal-turn gate ``--turn`` (deg, 0 off), no fold edges),
reads the Cycles image's colour edge field (sigma 1 px), and forms the object-pose gradient g and
the Gauss-Newton Hessian H of f_edge (the PSD part of E's pixel Hessian, as the solver's surrogate
without the curvature floor) over six degrees of freedom: turns about the model axes through the
model's centroid (deg) and moves along them (mm), cameras at the GT. The step -H^-1 g predicts
where f_edge alone moves the object; -H^-1 g_class splits it over the sample classes of
``bench_edge_pull.py`` (the steps add up). ``--obj all``: one row per object of the clip, the size
of each class's predicted turn (deg). Found with it (session 73): the CI scene's foam brick,
which the refiner turns ~1 deg about its model y axis from the exact GT, is turned by its interior
texture samples on the scan's baked shading along its bevelled edges (predicted 1.86 deg of 1.85).

    python bench/bench_edge_step.py --suite ycbv21-ci --dataset ../shared/data/ycbv --suite-root ROOT \
        --clip short-21 --obj 21 --out bench/results/ycbv21/s73/edge_step_ci_foam
    python bench/bench_edge_step.py --dataset ../shared/data/ycbv --suite-root ROOT --clip short-1 --obj all \
        --out bench/results/ycbv21/s73/edge_step_short1
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

DOFS = ("turn x (deg)", "turn y (deg)", "turn z (deg)", "move x (mm)", "move y (mm)", "move z (mm)")


def moved(X: np.ndarray, centre: np.ndarray, k: int, h: float) -> np.ndarray:
    """Model points X (N, 3, mm) turned by ``h`` deg about model axis k (k < 3, through ``centre``)
    or moved by ``h`` mm along model axis k - 3."""
    import cv2

    if k < 3:
        w = np.zeros(3)
        w[k] = np.radians(h)
        return (X - centre) @ cv2.Rodrigues(w)[0].T + centre
    d = np.zeros(3)
    d[k - 3] = h
    return X + d


def edge_step(models: dict, sc, obj: int, table_mm: float = 8.0, turn_deg: float = 0.0, sharp: float = 1.8,
              renderer=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """f_edge's gradient G (classes, 6), Gauss-Newton Hessian Hc (classes, 6, 6) and sample counts
    (classes,) of object ``obj`` at the exact GT over every frame of the clip scene ``sc`` (sample
    classes of :data:`bench_edge_pull.CLASSES`; DOFs of :data:`DOFS`)."""
    from bench_edge_pull import CLASSES, classed_samples   # this folder (run as a script)

    from ycbvss.refine.edge import edge_field, sample_field
    from ycbvss.refine.jacobians import project_points
    from ycbvss.refine.templates import render_view, view_edge_candidates

    centre = np.asarray(models[obj].vertices_mm, np.float64).mean(0)
    nc = len(CLASSES)
    G, Hc, cnt = np.zeros((nc, 6)), np.zeros((nc, 6, 6)), np.zeros(nc, int)
    for f in sc.frames:
        ids = [i.obj_id for i in f.instances]
        if obj not in ids:
            continue
        img = f.load_rgb()
        H, W = img.shape[:2]
        K = f.camera.K
        poses = {j: i.T_m2c for j, i in enumerate(f.instances)}
        vr = render_view(renderer, models, ids, K, W, H, poses, back=True)
        c = view_edge_candidates(vr, creases=True, blur_sigma_px=1.0, normals=True, interior_max_turn_deg=turn_deg,
                                 fold_min_angle_deg=180.0, interior_min_sharpness=sharp, junction_px=3.0 * W / 640.0)
        j = ids.index(obj)
        if j not in vr.obj_index:
            continue
        T = poses[j]
        fld = edge_field(img, 1.0, colour=True)
        for _, _, X, cls in classed_samples(vr, c, K, T, vr.obj_index.index(j) + 1, f.T_w2c, table_mm, 3.0 * W / 640.0):
            if not len(X):
                continue
            uv0, ok = project_points(K, T, X)
            _, g, Hx, inside = sample_field(fld, np.where(ok[:, None], uv0, -1e9))
            ok &= inside
            J = np.zeros((len(X), 2, 6))
            for k in range(6):
                up, _ = project_points(K, T, moved(X, centre, k, 0.05))
                um, _ = project_points(K, T, moved(X, centre, k, -0.05))
                J[:, :, k] = (up - um) / 0.1
            ev, V = np.linalg.eigh(Hx)
            A = np.einsum("nij,nj,nkj->nik", V, np.maximum(ev, 0.0), V)
            gJ = np.einsum("ni,nik->nk", g, J)
            JAJ = np.einsum("nik,nij,njl->nkl", J, A, J)
            for k in range(nc):
                s_ = ok & (cls == k)
                G[k] += gJ[s_].sum(0)
                Hc[k] += JAJ[s_].sum(0)
                cnt[k] += int(s_.sum())
    return G, Hc, cnt


def main() -> None:
    from bench_edge_pull import CLASSES   # this folder (run as a script)

    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.pipeline.suite import load_clip
    from ycbvss.refine.templates import ensure_meshes, get_renderer

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite", default="ycbv21")
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--clip", required=True)
    ap.add_argument("--obj", required=True, help="object id, or 'all': one summary row per object of the clip")
    ap.add_argument("--table-mm", type=float, default=8.0, help="free contour samples this close to the table: own class")
    ap.add_argument("--turn", type=float, default=0.0, help="interior normal-turn gate (deg, 0 off; RefineOptions.interior_max_turn_deg)")
    ap.add_argument("--sharp", type=float, default=1.8, help="interior sharpness gate (RefineOptions.interior_min_sharpness)")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    models, sc = load_clip(a.dataset, a.suite_root, a.clip, suite=a.suite)
    r = get_renderer()
    ensure_meshes(r, models)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    gates = f"interior turn gate {a.turn:g} deg, sharpness gate {a.sharp:g}"
    if a.obj == "all":
        objs = sorted({i.obj_id for f in sc.frames for i in f.instances})
        rows = []
        for o in objs:
            G, Hc, cnt = edge_step(models, sc, o, a.table_mm, a.turn, a.sharp, r)
            Ht = Hc.sum(0)
            if np.linalg.matrix_rank(Ht) < 6:        # (nearly) hidden in every frame: its pose is not observed
                rows.append(Row(models[o].name, [int(cnt.sum())] + [None] * (len(CLASSES) + 1)))
                continue
            turn = lambda g: float(np.linalg.norm(-np.linalg.solve(Ht, g)[:3]))
            rows.append(Row(models[o].name, [int(cnt.sum()), turn(G.sum(0))] + [turn(G[k]) for k in range(len(CLASSES))]))
        t = Table(caption=f"{a.clip} at the exact GT, cameras at the GT: the size of f_edge's one-step turn (deg) per "
                          f"object, from all samples and from each sample class alone (H of all samples; {gates}); "
                          f"a rotationally symmetric object's turn includes the one about its own axis, which its "
                          f"contour does not fix; f_edge alone: f_point holds a textured object's turns in the refiner",
                  label_header="object", columns=["samples", "all (deg)", *[f"{c} (deg)" for c in CLASSES]],
                  rows=rows, digits=3)
        for p in write_table(t, out, "edge_step_objects"):
            print(p)
        return
    obj = int(a.obj)
    G, Hc, cnt = edge_step(models, sc, obj, a.table_mm, a.turn, a.sharp, r)
    Ht = Hc.sum(0)
    rows = [Row(name, [int(cnt[k])] + [float(v) for v in -np.linalg.solve(Ht, G[k])]) for k, name in enumerate(CLASSES)]
    rows.append(Row("all samples", [int(cnt.sum())] + [float(v) for v in -np.linalg.solve(Ht, G.sum(0))], rule_before=True))
    t = Table(caption=f"{a.clip}, object {obj} ({models[obj].name}) at the exact GT, cameras at the GT: f_edge's "
                      f"one-step move -H^-1 g_class per sample class (H of all samples; {gates})",
              label_header="sample class", columns=["samples", *DOFS], rows=rows, digits=3)
    for p in write_table(t, out, "edge_step"):
        print(p)


if __name__ == "__main__":
    main()
