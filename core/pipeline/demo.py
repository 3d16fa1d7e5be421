"""`ycbvss demo`: no data needed. A procedural table-top scene (ycbvss.procedural) is rendered into a
BOP dataset (Blender by default, or the fast OpenGL renderer), then the whole validation loop runs
on it (perturb -> refine + ablations -> evaluate -> tables, figures, HTML report)."""
from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from .. import __version__
from ..errors import YcbvssError
from ..gt_info import compute_gt_info
from ..io.atomic import read_json, write_json_atomic, write_text_atomic
from ..io.bop import BopSceneWriter
from ..io.bop_dataset import write_camera_json, write_models_eval, write_targets
from ..procedural import make_scene, render_fast, write_models
from ..progress import progress
from ..render import Renderer
from .blender_scene import render_blender
from .validate import Stages, ValidateOptions, run_validate


@dataclass
class DemoOptions:
    out: Path = Path("ycbvss_demo")
    quick: bool = False
    frames: int | None = None
    width: int | None = None
    height: int | None = None
    seed: int = 0
    renderer: str = "blender"
    samples: int = 8
    denoise: bool = False
    workers: int = 1
    ablation: bool = True
    keyframe_step: int | None = None
    init_add_mm: float = 22.1
    init_prj_px: float | None = None     # None: 5.2 px scaled to the image width (5.2 at 640 px)
    overlays: int = 3

    def resolved(self) -> "DemoOptions":
        o = DemoOptions(**self.__dict__)
        o.frames = o.frames or (6 if o.quick else 24)
        o.width = o.width or (320 if o.quick else 640)
        o.height = o.height or (o.width * 3 // 4)
        if o.init_prj_px is None:
            o.init_prj_px = round(5.2 * o.width / 640.0, 3)
        return o

    def check(self) -> None:
        if self.renderer not in ("blender", "fast"):
            raise YcbvssError(f"--renderer must be 'blender' or 'fast', got {self.renderer!r}")
        if not (2 <= self.frames <= 400):
            raise YcbvssError(f"--frames must be in 2..400, got {self.frames}")
        if not (64 <= self.width <= 4096 and 48 <= self.height <= 4096):
            raise YcbvssError(f"image size {self.width}x{self.height} out of range (64x48 .. 4096x4096)")
        if self.samples < 1:
            raise YcbvssError(f"--samples must be >= 1, got {self.samples}")
        if self.workers < 1:
            raise YcbvssError(f"--workers must be >= 1, got {self.workers}")


def build_dataset(o: DemoOptions, stages: Stages) -> tuple[Path, object]:
    """Procedural scene -> BOP dataset under ``<out>/dataset`` (models/, test/000001/)."""
    root = Path(o.out) / "dataset"
    with stages.stage("build procedural scene"):
        scene = make_scene(seed=o.seed, n_frames=o.frames, width=o.width, height=o.height)
    with stages.stage(f"render {o.frames} frames ({o.renderer}, {o.width}x{o.height})"):
        writer = BopSceneWriter(root / "test", scene.scene_id)
        frames = {f.im_id: f for f in scene.frames}
        gl = Renderer()

        def write(im_id, rgb, depth):
            f = frames[im_id]
            masks, masks_visib, info = compute_gt_info(gl, f, scene.models, depth_mm_real=depth)
            writer.write_frame(f, rgb=rgb, depth_mm=depth, masks=masks, masks_visib=masks_visib, gt_info=info)

        if o.renderer == "blender":
            bar = progress(desc="render (Blender Cycles)", total=len(scene.frames), unit="frame")
            it = render_blender(scene, root / "models", Path(o.out) / "work" / "blender", samples=o.samples,
                                denoise=o.denoise, workers=o.workers, on_frame=lambda: bar.update(1))
            try:
                for im_id, rgb, depth in it:
                    write(im_id, rgb, depth)
            finally:
                bar.close()
            shutil.rmtree(Path(o.out) / "work", ignore_errors=True)
        else:
            write_models(scene, root / "models")
            for im_id, rgb, depth in progress(render_fast(scene), desc="render (fast)", total=len(scene.frames),
                                              unit="frame"):
                write(im_id, rgb, depth)
        writer.close()
    with stages.stage("dataset files (camera.json, targets, models_eval, dataset_info.md)"):
        f0 = scene.frames[0]
        write_camera_json(root, f0.camera.K, f0.camera.width, f0.camera.height, f0.depth_scale)
        write_targets(root, "test")
        write_models_eval(root, show_progress=False)
        write_text_atomic(root / "dataset_info.md", (
            f"# ycbvss demo dataset (ycbvss {__version__}, `ycbvss demo`)\n\nA procedural table-top scene "
            f"(seed {o.seed}), {o.frames} frames rendered with {o.renderer} at {o.width}x{o.height}; exact GT "
            "(the models in models/ are the rendered ones, not dilated). scene_gt_info.json and masks by "
            "bop_toolkit's calc_gt_info rules.\n"))
    return root, scene


def run_demo(opts: DemoOptions, stages: Stages | None = None) -> dict:
    o = opts.resolved()
    o.check()
    stages = stages or Stages()
    root, scene = build_dataset(o, stages)
    vo = ValidateOptions(dataset=root, out=Path(o.out), split="test", seed=o.seed, init_add_mm=o.init_add_mm,
                         init_prj_px=float(o.init_prj_px), gt_exact=True, ablation=o.ablation,
                         keyframe_step=o.keyframe_step, overlays=o.overlays,
                         title="ycbvss demo: bundle pose refinement on a procedural scene",
                         extra_info={"renderer": o.renderer, "image size": f"{o.width}x{o.height}",
                                     "frames": o.frames, "camera arc baseline (deg)": round(scene.baseline_deg, 1),
                                     "PRJ target note": "5.2 px at 640 px width, scaled with the image width"
                                     if opts.init_prj_px is None else "as given"})
    summary = run_validate(vo, stages)
    summary["mode"] = "demo"                 # the validate loop on the demo's own procedural dataset
    sp = Path(o.out) / "summary.json"
    if sp.is_file():
        write_json_atomic(sp, {**read_json(sp), "mode": "demo"})
    return summary
