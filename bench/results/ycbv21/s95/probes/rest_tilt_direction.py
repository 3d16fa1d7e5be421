"""Session 95 probe: each object's rotation rest (mean over its poses of the rows' model-frame
rotation-error vector) turned into the world frame (z up, the table), split into the tilt of a vertical
normal towards the mean camera direction, sideways, and the elevation of the cameras.
Run from the repository root: python bench/results/ycbv21/s95/probes/rest_tilt_direction.py ROWS.csv ...
(suite_runs.py rows of a suite rendered at /tmp/suite/full). The .txt beside it:
bench/results/ycbv21/s94/rows/s94_long1_gt_seed0_linear_contrast.csv.gz bench/results/ycbv21/s95/rows/s95_reused_long2_gt_seed0.csv.gz bench/results/ycbv21/s94/rows/s94_long3_gt_seed0_linear_contrast.csv.gz."""
import pandas as pd, numpy as np, json, sys
a=pd.concat([pd.read_csv(f) for f in sys.argv[1:]])
names={1:'chef',2:'cracker',3:'sugar',4:'soup',5:'mustard',6:'tuna',7:'pudding',8:'gelatin',9:'meat',10:'banana',11:'pitcher',12:'bleach',13:'bowl',14:'mug',15:'drill',16:'wood',17:'scissors',18:'marker',19:'Lclamp',20:'XLclamp',21:'foam'}
for (clip,oid),g in a.groupby(['clip','obj_id']):
    sid=int(g['scene_id'].iloc[0]); d=f'/tmp/suite/full/test/{sid:06d}'
    cam=json.load(open(d+'/scene_camera.json')); gt=json.load(open(d+'/scene_gt.json'))
    W=[];C=[];
    for _,r in g.iterrows():
        im=str(int(r['im_id']))
        Rwc=np.array(cam[im]['cam_R_w2c']).reshape(3,3); twc=np.array(cam[im]['cam_t_w2c'])
        x=[x for x in gt[im] if x['obj_id']==oid][0]
        Rmc=np.array(x['cam_R_m2c']).reshape(3,3); tmc=np.array(x['cam_t_m2c'])
        Rwm=Rwc.T@Rmc; p_w=Rwc.T@(tmc-twc); c_w=-Rwc.T@twc
        W.append(Rwm@[r['rx_obj_deg'],r['ry_obj_deg'],r['rz_obj_deg']]); v=c_w-p_w; C.append(v/np.linalg.norm(v))
    w=np.mean(W,0); c=np.mean(C,0)
    up=np.array([0,0,1.]); dn=np.cross(np.radians(w),up)   # change of a vertical normal
    ch=c.copy(); ch[2]=0; 
    elev=np.degrees(np.arcsin(c[2]))
    along=np.degrees(dn@ch/np.linalg.norm(ch)); perp=np.degrees(np.linalg.norm(dn-(dn@ch)*ch/np.linalg.norm(ch)**2))
    # change of |n.c| (foreshortening) per unit: dn . c
    print(f"{clip} {names[oid]:8s} R={np.linalg.norm(w):.3f} yaw={w[2]:+.3f} tilt={np.hypot(w[0],w[1]):.3f} toward-camera={along:+.3f} deg  sideways={perp:.3f}  elev={elev:.0f}")
