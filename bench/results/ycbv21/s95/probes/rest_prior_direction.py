"""Session 95 probe: for each object, the tilt the resting-face prior (refine.table_rest, the official
points.xyz hull) asks for at the exact GT (the suite stands each object on a face of the scan), against
the object's rotation rest's tilt (world x, y, deg). Run from the repository root with suite_runs.py rows:
python bench/results/ycbv21/s95/probes/rest_prior_direction.py ROWS.csv ...
(the suite rendered at /tmp/suite/full). The .txt beside it: bench/results/ycbv21/s94/rows/s94_long1_gt_seed0_linear_contrast.csv.gz bench/results/ycbv21/s95/rows/s95_reused_long2_gt_seed0.csv.gz bench/results/ycbv21/s94/rows/s94_long3_gt_seed0_linear_contrast.csv.gz."""
import pandas as pd, numpy as np, json, sys, warnings
warnings.filterwarnings('ignore')
from ycbvss.refine.table_rest import rest_faces
from ycbvss.io.ycbv import model_center_mm
import os
root='../shared/data/ycbv/models/'
names=sorted(os.listdir(root))
a=pd.concat([pd.read_csv(f) for f in sys.argv[1:]])
for (clip,oid),g in a.groupby(['clip','obj_id']):
    n=names[oid-1]
    P=np.loadtxt(root+n+'/points.xyz')*1000.0-model_center_mm(root+n+'/textured.obj')
    F=rest_faces(P,1.0)
    sid=int(g['scene_id'].iloc[0]); d=f'/tmp/suite/full/test/{sid:06d}'
    cam=json.load(open(d+'/scene_camera.json')); gt=json.load(open(d+'/scene_gt.json'))
    im=str(int(g['im_id'].iloc[0]))
    Rwc=np.array(cam[im]['cam_R_w2c']).reshape(3,3)
    Rmc=[np.array(x['cam_R_m2c']).reshape(3,3) for x in gt[im] if x['obj_id']==oid][0]
    Rwm=Rwc.T@Rmc
    dm=Rwm.T@np.array([0,0,-1.])
    j=int(np.argmax(F.down@dm)); fw=Rwm@F.down[j]
    om=np.degrees(np.cross(fw,[0,0,-1.]))   # world rotation that puts the official face flat
    W=np.mean([Rwm@[r['rx_obj_deg'],r['ry_obj_deg'],r['rz_obj_deg']] for _,r in g.iterrows()],0)
    print(f"{clip} {n:24s} face-off={np.degrees(np.arccos(np.clip(F.down[j]@dm,-1,1))):.3f}  prior pull(xy)=({om[0]:+.3f},{om[1]:+.3f})  rest tilt(xy)=({W[0]:+.3f},{W[1]:+.3f})")
