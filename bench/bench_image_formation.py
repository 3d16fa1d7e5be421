"""Does f_point's apparent-scale bias come from the image formation itself? Match scale at the exact GT
against Blender renders of suite frames with the texture as *emission* (no lights, no shading):
only the camera's sampling, Cycles' pixel filter and the denoiser differ from the fast renderer.

For each image variant (samples, denoiser, pixel filter width) the chosen frames of the long
``ycbv21`` scenes are rendered once (cached under ``--out``), then the least-squares scale of the
template-to-image flow matches about their centroid is measured as in ``bench_match_scale.py``, for
templates sampled at the pixel centres (``--supersample 1``) and integrated over the pixel area.

    python bench/bench_image_formation.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --out /tmp/image_formation --variants "12,1,1.0;128,0,1.0;64,0,0.01" --supersample 1,2
"""
from __future__ import annotations

import argparse
import shutil
import warnings
from pathlib import Path

import numpy as np


def render_emission(spec, models: dict, root: Path, frames: list[int], samples: int, denoise: bool,
                    filter_width: float) -> Path:
    """Blender-render ``frames`` of suite scene ``spec`` with the emission material into a BOP root."""
    from ycbvss.gt_info import compute_gt_info
    from ycbvss.io.bop import BopSceneWriter
    from ycbvss.pipeline.blender_scene import render_blender
    from ycbvss.procedural.ycbv_scene import make_ycbv_scene
    from ycbvss.render import Renderer

    if (root / "test" / f"{spec.scene_id:06d}" / "scene_gt.json").is_file():
        return root
    sc = make_ycbv_scene(models, list(spec.obj_ids), seed=spec.seed, n_frames=spec.n_frames,
                         arc_deg=spec.arc_deg, width=640, height=480, scene_id=spec.scene_id)
    sc.frames = [f for f in sc.frames if f.im_id in set(frames)]
    gl = Renderer()
    writer = BopSceneWriter(root / "test", spec.scene_id)
    by_id = {f.im_id: f for f in sc.frames}
    for im_id, rgb, depth in render_blender(sc, root / "models", root / "work", samples=samples, denoise=denoise,
                                            material="emission", filter_width=filter_width):
        masks, masks_visib, info = compute_gt_info(gl, by_id[im_id], models, depth_mm_real=depth)
        writer.write_frame(by_id[im_id], rgb=rgb, depth_mm=depth, masks=masks, masks_visib=masks_visib,
                           gt_info=info)
    writer.close()
    return root


def match_scales(a: argparse.Namespace, images: Path | None, supersample: int) -> list[tuple[int, float]]:
    """(obj_id, scale) per (view, object) with at least 30 matches (``bench_match_scale``'s measure)."""
    from bench_contour_offsets import gt_view_matches, gt_views   # this folder (run as a script)

    ns = argparse.Namespace(suite_root=a.suite_root, dataset=a.dataset, scenes=a.scenes, frames=a.frames,
                            supersample=supersample, images=str(images) if images else None)
    out = []
    for _, _, _, img, vr, oids in gt_views(ns):
        objs, matches = gt_view_matches(vr, img)
        for j, (xs, xd) in zip(objs, matches):
            if len(xs) < 30:
                continue
            rel = xs - xs.mean(axis=0)
            out.append((oids[j], float(np.sum((xd - xs) * rel) / np.sum(rel * rel))))
    return out


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.pipeline.suite import YCBV21, suite_models

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--scenes", default="1,2,3")
    ap.add_argument("--frames", default="0,50,100,150", help="frame ids rendered (and measured) per scene")
    ap.add_argument("--variants", default="12,1,1.0;128,0,1.0;64,0,0.01",
                    help="image variants 'samples,denoise,filter_width;...' (the suite's own: 12,1,1.0)")
    ap.add_argument("--supersample", default="1,2")
    ap.add_argument("--out", required=True, type=Path)
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    frames = [int(x) for x in a.frames.split(",")]
    scene_ids = [int(s) for s in a.scenes.split(",")]
    t = Table(["groups", "scale mean (%)", "sem (%)", "depth pull at 1.3 m (mm)"], label_header="images / template",
              digits=4, caption="f_point's flow matches at the exact GT against emission-only Blender renders "
                                f"(scenes {a.scenes}, frames {a.frames}): least-squares scale about their centroid")
    for v in a.variants.split(";"):
        spp, dn, fw = v.split(",")
        root = a.out / f"emission_s{int(spp)}_d{int(dn)}_f{float(fw):g}"
        for sid in scene_ids:
            spec = next(s for s in YCBV21 if s.scene_id == sid)
            models = suite_models(a.dataset, root / "models_src", spec.obj_ids)
            if not (root / "models").is_dir():
                shutil.copytree(root / "models_src" / "models", root / "models")
            render_emission(spec, models, root, frames, int(spp), bool(int(dn)), float(fw))
        for ss in [int(x) for x in a.supersample.split(",")]:
            s = np.array([x[1] for x in match_scales(a, root, ss)])
            label = f"{spp} spp, denoiser {'on' if int(dn) else 'off'}, filter {fw} px / template {ss}x{ss}"
            print(f"{label}: groups {len(s)}, scale {100 * s.mean():+.4f} % (sem {100 * s.std() / np.sqrt(len(s)):.4f})")
            t.rows.append(Row(label, [float(len(s)), 100 * float(s.mean()), 100 * float(s.std() / np.sqrt(len(s))),
                                      -1300.0 * float(s.mean())]))
    for p in write_table(t, a.out, "image_formation"):
        print(p)


if __name__ == "__main__":
    main()
