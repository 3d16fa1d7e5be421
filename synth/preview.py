"""Visual QA of a YCBV-SS output: per frame ``original | YCBV-SS | contours on the original`` and a
contact sheet per scene."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..errors import YcbvssError
from ..io.atomic import read_json
from ..io.images import read_mask, read_rgb, write_png
from ..progress import progress

COLOURS = [(255, 64, 64), (64, 255, 64), (64, 128, 255), (255, 255, 0), (255, 0, 255), (0, 255, 255),
           (255, 160, 0), (160, 0, 255)]


def triptych(orig: np.ndarray, synth: np.ndarray, masks_visib: list[np.ndarray]) -> np.ndarray:
    """(H, 3W, 3) uint8: original | YCBV-SS | original with the YCBV-SS visible-mask contours."""
    ov = orig.copy()
    for k, m in enumerate(masks_visib):
        cs, _ = cv2.findContours(m.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        cv2.drawContours(ov, cs, -1, COLOURS[k % len(COLOURS)], 1)
    return np.concatenate([orig, synth, ov], axis=1)


def contact_sheet(images: list[np.ndarray], cols: int = 4, thumb_w: int = 480) -> np.ndarray:
    thumbs = []
    for im in images:
        h, w = im.shape[:2]
        thumbs.append(cv2.resize(im, (thumb_w, max(1, int(round(h * thumb_w / w)))), interpolation=cv2.INTER_AREA))
    th = max(t.shape[0] for t in thumbs)
    rows = []
    for i in range(0, len(thumbs), cols):
        row = [np.pad(t, ((0, th - t.shape[0]), (0, 0), (0, 0))) for t in thumbs[i:i + cols]]
        row += [np.zeros((th, thumb_w, 3), np.uint8)] * (cols - len(row))
        rows.append(np.concatenate(row, axis=1))
    return np.concatenate(rows, axis=0)


def write_preview(dataset: str | Path, split: str = "test", out: str | Path | None = None,
                  scenes: list[int] | None = None, max_sheet: int = 24) -> Path:
    """Write ``<out>/<scene>/<im_id>.png`` triptychs and ``<out>/<scene>_contact.png`` (default out: DATASET/preview)."""
    root = Path(dataset)
    split_dir = root / split
    if not split_dir.is_dir():
        raise YcbvssError("not a YCBV-SS output (no split folder)", split_dir)
    out = Path(out) if out else root / "preview"
    sids = sorted(int(p.name) for p in split_dir.iterdir() if p.is_dir() and p.name.isdigit())
    if scenes is not None:
        sids = [s for s in sids if s in set(scenes)]
    for sid in sids:
        sdir = split_dir / f"{sid:06d}"
        markers = sorted((sdir / ".done").glob("[0-9]*.json")) if (sdir / ".done").is_dir() else []
        sheet = []
        ok = [read_json(p) for p in markers]
        ok = [m for m in ok if not m.get("skipped")]
        pick = set(np.linspace(0, len(ok) - 1, min(max_sheet, len(ok))).round().astype(int).tolist()) if ok else set()
        for i, m in enumerate(progress(ok, desc=f"preview scene {sid}", unit="frame")):
            iid = int(m["im_id"])
            orig = read_rgb(m["src_rgb"], f"scene {sid} frame {iid}")
            syn = read_rgb(sdir / "rgb" / f"{iid:06d}.png", f"scene {sid} frame {iid}")
            mv = [read_mask(sdir / "mask_visib" / f"{iid:06d}_{k:06d}.png") for k in range(len(m["scene_gt"]))]
            t = triptych(orig, syn, mv)
            write_png(out / f"{sid:06d}" / f"{iid:06d}.png", t)
            if i in pick:
                sheet.append(t)
        if sheet:
            write_png(out / f"{sid:06d}_contact.png", contact_sheet(sheet, cols=2, thumb_w=960))
    return out
