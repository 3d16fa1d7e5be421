"""Probe: image vs lit template by distance inside each silhouette, at the exact GT (linear light)."""
import sys, argparse
sys.path.insert(0, "/work/main/bench")
import numpy as np
from scipy.ndimage import distance_transform_edt
from bench_contour_offsets import add_view_args, gt_views
from ycbvss.refine.shading import lit_template
from ycbvss.refine.edge import srgb_to_linear
ap = argparse.ArgumentParser(); add_view_args(ap)
ap.add_argument("--other-images", default=None)
a = ap.parse_args()
bands = [(0, 1), (1, 2), (2, 3), (3, 5), (5, 10)]
acc = {}
names = {}
for models, sid, fr, img, vr, oids in gt_views(a):
    lit = lit_template(vr.color, vr.normal, vr.instance, img)
    L_img = srgb_to_linear(img).astype(np.float64)
    L_lit = srgb_to_linear(lit).astype(np.float64)
    L_unl = srgb_to_linear(vr.color).astype(np.float64)
    for lab0, oid in enumerate(oids):
        m = vr.instance == lab0 + 1
        if m.sum() < 200: continue
        # distance inside; only pixels whose nearest outside is background (not another object)? keep all for now
        d = distance_transform_edt(m)
        names[oid] = models[oid].name if hasattr(models[oid], "name") else str(oid)
        for bi, (lo, hi) in enumerate(bands):
            sel = m & (d > lo) & (d <= hi)
            if sel.sum() < 10: continue
            r = (L_img[sel].mean(1) - L_lit[sel].mean(1))
            acc.setdefault((oid, bi), []).append((r.mean(), L_lit[sel].mean(), L_img[sel].mean()))
print("obj | " + " | ".join(f"d {lo}-{hi}: img-lit (lit)" for lo, hi in bands))
for oid in sorted(names):
    cells = []
    for bi in range(len(bands)):
        v = np.array(acc.get((oid, bi), [[np.nan] * 3]))
        cells.append(f"{v[:,0].mean():+6.2f} ({v[:,1].mean():5.1f})")
    print(f"{names[oid][:22]:22s} | " + " | ".join(cells))
