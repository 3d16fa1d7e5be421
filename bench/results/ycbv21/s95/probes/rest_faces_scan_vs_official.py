"""Session 95 probe: the three most probable stable faces of each official points.xyz hull, the angle
(deg) to the nearest stable face of the textured scan's hull, and the 1-sigma tilt (deg) that
refine.table_rest's prior gives the face at table_rest_acc_mm = 1. Run from the repository root with
../shared/data beside it: python bench/results/ycbv21/s95/probes/rest_faces_scan_vs_official.py"""
import numpy as np, trimesh, glob, warnings
warnings.filterwarnings('ignore')
from ycbvss.refine.table_rest import rest_faces
root='../shared/data/ycbv/models/'
import os
for n in sorted(os.listdir(root)):
    P=np.loadtxt(root+n+'/points.xyz')*1000.0
    m=trimesh.load(root+n+'/textured.obj',force='mesh'); V=np.asarray(m.vertices)*1000.0
    fa=rest_faces(P,1.0); fb=rest_faces(V,1.0)
    out=[]
    for i in np.argsort(-fa.prob)[:3]:
        d=fa.down[i]; sig=np.degrees(1/np.sqrt(np.linalg.eigvalsh(fa.L[i]@fa.L[i].T)))
        ang=[np.degrees(np.arccos(np.clip(d@fb.down[j],-1,1))) for j in range(len(fb.prob))]
        j=int(np.argmin(ang)) if ang else -1
        out.append(f"p={fa.prob[i]:.2f} dang={ang[j]:.3f} sig={sig.round(2)}" if ang else "none")
    print(f"{n:24s} faces {len(fa.prob):2d}/{len(fb.prob):2d} | "+" | ".join(out))
