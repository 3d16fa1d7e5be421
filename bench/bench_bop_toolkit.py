"""Run the reference BOP toolkit on a dataset written by ycbvss (not run in CI: it needs a bop_toolkit checkout).

    python bench/bench_bop_toolkit.py --bop-toolkit /path/to/bop_toolkit --python /path/to/venv/bin/python \
        --dataset EXPORT_ROOT --split test --results est.csv [more.csv ...] --work /tmp/boptk_run

The bop_toolkit checkout is used as it is, in its own Python environment (``--python``; bop_toolkit needs
numpy < 2, vispy, pyopengl, pypng, imageio, scikit-image). Nothing of it is imported into ycbvss.
Steps, all with bop_toolkit's code (the dataset is presented to it as ``ycbv`` through a tree of links,
scene s as s + ``--scene-offset``: bop_toolkit's ycbv test split is scenes 48-59):

1. loaders: ``dataset_params`` (split, models, models_eval, camera), ``inout.load_scene_gt/camera``,
   ``load_json`` of scene_gt_info, ``load_ply`` of every model and models_eval model, ``load_depth``,
   the mask PNGs and the targets file;
2. ``scripts/calc_gt_info.py`` and ``scripts/calc_gt_masks.py`` run (parameters set through their ``p``
   dicts / arguments) on a copy of the split's JSON files, then every field and mask is compared with
   what ycbvss wrote (the vispy renderer runs headless with EGL_PLATFORM=surfaceless);
3. ``scripts/eval_bop19_pose.py`` (VSD, MSSD, MSPD; vispy renderer on EGL) on each results CSV, copied
   to ``<name>_ycbv-<split>.csv`` as BOP requires; the scores are printed.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

LOADER_CHECK = r'''
import json, os, sys, glob
import numpy as np
from bop_toolkit_lib import dataset_params, inout
dp = os.environ["BOP_PATH"]; split = sys.argv[1]
sp = dataset_params.get_split_params(dp, "ycbv", split)
mp = dataset_params.get_model_params(dp, "ycbv")
mpe = dataset_params.get_model_params(dp, "ycbv", "eval")
cam = dataset_params.get_camera_params(dp, "ycbv")
scenes = dataset_params.get_present_scene_ids(sp)
n_gt = n_img = n_mask = 0
for s in scenes:
    gt = inout.load_scene_gt(sp["scene_gt_tpath"].format(scene_id=s))
    sc = inout.load_scene_camera(sp["scene_camera_tpath"].format(scene_id=s))
    info = inout.load_json(sp["scene_gt_info_tpath"].format(scene_id=s), keys_to_int=True)
    for im, insts in gt.items():
        d = inout.load_depth(sp["depth_tpath"].format(scene_id=s, im_id=im))
        assert d.shape == (480, 640) and "cam_R_w2c" in sc[im]
        rgb = inout.load_im(sp["rgb_tpath"].format(scene_id=s, im_id=im))
        n_img += 1
        assert len(info[im]) == len(insts)
        for g in range(len(insts)):
            m = inout.load_im(sp["mask_visib_tpath"].format(scene_id=s, im_id=im, gt_id=g))
            n_mask += 1
        n_gt += len(insts)
models = {}
for kind, p in (("models", mp), ("models_eval", mpe)):
    info = inout.load_json(p["models_info_path"], keys_to_int=True)
    for o in sorted(info):
        m = inout.load_ply(p["model_tpath"].format(obj_id=o))
        models.setdefault(kind, []).append(len(m["pts"]))
targets = inout.load_json(os.path.join(sp["base_path"], sys.argv[2]))
print(json.dumps({"scenes": scenes, "images": n_img, "gt_instances": n_gt, "masks": n_mask,
                  "models": len(models["models"]), "models_eval": len(models["models_eval"]),
                  "models_eval_points": [min(models["models_eval"]), max(models["models_eval"])],
                  "camera_uw": {k: cam[k] for k in ("im_size",)}, "targets": len(targets)}, default=str))
'''


def _run(cmd, env, cwd, log):
    t0 = time.perf_counter()
    print("$", " ".join(str(c) for c in cmd), flush=True)
    r = subprocess.run([str(c) for c in cmd], env=env, cwd=cwd, capture_output=True, text=True)
    log.write(r.stdout + r.stderr)
    if r.returncode != 0:
        print(r.stdout[-3000:], r.stderr[-3000:], file=sys.stderr)
        raise SystemExit(f"failed ({r.returncode}): {' '.join(str(c) for c in cmd)}")
    return r.stdout, time.perf_counter() - t0


def _patched_script(src: Path, dst: Path, values: dict) -> Path:
    """bop_toolkit's script with the given keys of its module-level ``p`` dict set (the script itself is
    not changed; a copy under the work folder gets an assignment after the dict)."""
    text = src.read_text()
    marker = "################################################################################\n\n"
    i = text.index('p = {')
    j = text.index(marker, i) + len(marker)
    text = text[:j] + "".join(f"p[{k!r}] = {v!r}\n" for k, v in values.items()) + text[j:]
    dst.write_text(text)
    return dst


def build_shadow(src: Path, split: str, dst: Path, offset: int, tfile: str, own_gt_info: bool) -> dict:
    """A tree of links presenting ``src`` to bop_toolkit as ``ycbv``, scene s as s + offset (bop_toolkit's ycbv
    test split is scenes 48-59). With ``own_gt_info`` only scene_gt/scene_camera are copied (rgb, depth linked)
    so bop_toolkit's scripts write their own scene_gt_info.json and masks. Returns {src scene: shadow scene}."""
    if dst.exists() or dst.is_symlink():
        shutil.rmtree(dst) if dst.is_dir() and not dst.is_symlink() else dst.unlink()
    dst.mkdir(parents=True)
    for p in src.iterdir():
        if p.name not in (split, tfile):
            (dst / p.name).symlink_to(p)
    smap = {}
    for sdir in sorted(p for p in (src / split).iterdir() if p.name.isdigit()):
        s = int(sdir.name)
        smap[s] = s + offset
        d = dst / split / f"{s + offset:06d}"
        d.mkdir(parents=True)
        for p in sdir.iterdir():
            if own_gt_info and p.name not in ("rgb", "depth", "scene_gt.json", "scene_camera.json"):
                continue
            if own_gt_info and p.suffix == ".json":
                shutil.copyfile(p, d / p.name)
            else:
                (d / p.name).symlink_to(p)
    targets = json.loads((src / tfile).read_text())
    for t in targets:
        t["scene_id"] = smap[t["scene_id"]]
    (dst / tfile).write_text(json.dumps(targets))
    return smap


def compare_gt_info(ours_dir: Path, bop_dir: Path, offset: int) -> dict:
    """Largest differences between the ycbvss-written and the bop_toolkit-written scene_gt_info/masks."""
    import numpy as np
    import cv2
    worst = {"px_count_all": 0, "px_count_valid": 0, "px_count_visib": 0, "visib_fract": 0.0, "bbox_obj": 0,
             "bbox_visib": 0, "mask_px": 0, "mask_visib_px": 0, "n": 0, "sum_px_visib": 0}
    for sdir in sorted(p for p in bop_dir.iterdir() if p.name.isdigit()):
        ours = ours_dir / f"{int(sdir.name) - offset:06d}"
        a = json.loads((ours / "scene_gt_info.json").read_text())
        b = json.loads((sdir / "scene_gt_info.json").read_text())
        for im in b:
            for g, (x, y) in enumerate(zip(a[im], b[im])):
                for k in ("px_count_all", "px_count_valid", "px_count_visib", "visib_fract"):
                    worst[k] = max(worst[k], abs(x[k] - y[k]))
                for k in ("bbox_obj", "bbox_visib"):
                    worst[k] = max(worst[k], int(np.abs(np.subtract(x[k], y[k])).max()))
                for sub, key in (("mask", "mask_px"), ("mask_visib", "mask_visib_px")):
                    f = f"{int(im):06d}_{g:06d}.png"
                    ma = cv2.imread(str(ours / sub / f), cv2.IMREAD_UNCHANGED) > 0
                    mb = cv2.imread(str(sdir / sub / f), cv2.IMREAD_UNCHANGED) > 0
                    worst[key] = max(worst[key], int((ma ^ mb).sum()))
                worst["n"] += 1
                worst["sum_px_visib"] += y["px_count_visib"]
    return worst


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bop-toolkit", required=True, type=Path, help="bop_toolkit checkout (scripts/, bop_toolkit_lib/)")
    ap.add_argument("--python", default=sys.executable, help="Python of an environment where bop_toolkit_lib imports")
    ap.add_argument("--dataset", required=True, type=Path, help="BOP root written by ycbvss (export/convert/synth)")
    ap.add_argument("--split", default="test", help="split (bop_toolkit's ycbv knows test and train)")
    ap.add_argument("--results", nargs="*", default=[], type=Path, help="BOP19 CSVs to evaluate")
    ap.add_argument("--work", required=True, type=Path, help="work folder (datasets link, results, eval)")
    ap.add_argument("--renderer", default="vispy", help="bop_toolkit renderer type for VSD and gt_info")
    ap.add_argument("--skip-gt-info", action="store_true")
    ap.add_argument("--scene-offset", type=int, default=0,
                    help="present scene s as s + OFFSET (bop_toolkit's ycbv test scenes are 48-59; 48 for videos 0, 1)")
    a = ap.parse_args(argv)
    tk = a.bop_toolkit.resolve()
    work = a.work.resolve()
    src = a.dataset.resolve()
    tfile = "test_targets_bop19.json" if a.split == "test" else f"{a.split}_targets_bop19.json"
    smap = build_shadow(src, a.split, work / "datasets" / "ycbv", a.scene_offset, tfile, own_gt_info=False)
    env = {**os.environ, "BOP_PATH": str(work / "datasets"), "BOP_RESULTS_PATH": str(work / "results"),
           "BOP_EVAL_PATH": str(work / "eval"), "BOP_NUM_WORKERS": "1", "PYTHONPATH": str(tk),
           "EGL_PLATFORM": os.environ.get("EGL_PLATFORM", "surfaceless"),
           # eval_bop19_pose.py starts `python scripts/...`: the bop_toolkit environment's python first on PATH
           "PATH": str(Path(a.python).parent) + os.pathsep + os.environ.get("PATH", "")}
    log = open(work / "bop_toolkit.log", "w")
    # 1. loaders
    out, dt = _run([a.python, "-c", LOADER_CHECK, a.split, tfile], env, tk, log)
    print(f"[loaders] {out.strip()}  ({dt:.1f} s)")
    # 2. calc_gt_info / calc_gt_masks on a shadow copy (links to everything, own JSON/mask folders)
    if not a.skip_gt_info:
        shadow = work / "shadow" / "ycbv"
        build_shadow(src, a.split, shadow, a.scene_offset, tfile, own_gt_info=True)
        env2 = {**env, "BOP_PATH": str(work / "shadow")}
        s1 = _patched_script(tk / "scripts" / "calc_gt_info.py", work / "calc_gt_info_run.py",
                             {"dataset": "ycbv", "dataset_split": a.split, "renderer_type": a.renderer,
                              "datasets_path": str(work / "shadow"), "modality": None, "sensor": None,
                              "vis_visibility_masks": False})
        _, dt1 = _run([a.python, s1], env2, tk, log)
        _, dt2 = _run([a.python, tk / "scripts" / "calc_gt_masks.py", "--dataset", "ycbv", "--dataset_split",
                       a.split, "--datasets_path", str(work / "shadow"), "--renderer_type", a.renderer,
                       "--use_all_gt"], env2, tk, log)
        w = compare_gt_info(src / a.split, shadow / a.split, a.scene_offset)
        print(f"[calc_gt_info + calc_gt_masks, {dt1 + dt2:.1f} s] largest |ycbvss - bop_toolkit| over "
              f"{w['n']} instances ({w['sum_px_visib']} visible px): {json.dumps(w)}")
    # 3. eval_bop19_pose
    (work / "results").mkdir(exist_ok=True)
    names = []
    for k, r in enumerate(a.results):
        stem = re.sub(r"[^A-Za-z0-9]", "", r.stem.split("_")[0]) or f"method{k}"
        name = f"{stem}{k}_ycbv-{a.split}.csv"
        lines = r.read_text().splitlines()
        rows = [lines[0]] + [",".join([str(smap[int(x.split(",", 1)[0])])] + x.split(",")[1:]) for x in lines[1:] if x]
        (work / "results" / name).write_text("\n".join(rows) + "\n")
        names.append(name)
    for name in names:
        _, dt = _run([a.python, tk / "scripts" / "eval_bop19_pose.py", "--renderer_type", a.renderer,
                      "--result_filenames", name, "--results_path", work / "results", "--eval_path", work / "eval",
                      "--targets_filename", tfile, "--num_workers", "1"], env, tk, log)
        scores = json.loads((work / "eval" / Path(name).stem / "scores_bop19.json").read_text())
        keep = {k: round(v, 4) for k, v in scores.items() if k.startswith("bop19_average_recall")}
        print(f"[eval_bop19_pose {name}, {dt:.1f} s] {json.dumps(keep)}")
    print(f"log: {work / 'bop_toolkit.log'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
