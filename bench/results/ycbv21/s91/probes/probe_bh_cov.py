"""Probe (not kept): the synthetic image's coverage remapped from an area pixel to Cycles' 1 px
Blackman-Harris footprint, cov' = F_BH(cov - 0.5) (exact for a straight axis-aligned edge). Env BH_REMAP=1."""
import os, sys
import numpy as np
sys.path.insert(0, "/work/main/bench")
import ycbvss.refine.contour_match as cm
import ycbvss.refine.templates as tp
if os.environ.get("BH_REMAP", "1") == "1":
    x = np.linspace(-0.5, 0.5, 2001)
    xx = 2 * np.pi * (x + 0.5)
    w = 0.35875 - 0.48829 * np.cos(xx) + 0.14128 * np.cos(2 * xx) - 0.01168 * np.cos(3 * xx)
    F = np.cumsum(w); F = (F - F[0]) / (F[-1] - F[0])
    _si = cm.synthetic_image
    def si(instance, coverage, colour, image, ring_px=2.5, psf_sigma_px=0.0):
        if coverage is not None:
            coverage = np.interp(np.clip(np.asarray(coverage, np.float64), 0, 1) - 0.5, x, F).astype(np.float32)
        return _si(instance, coverage, colour, image, ring_px, psf_sigma_px)
    cm.synthetic_image = si
    tp.synthetic_image = si
import runpy
sys.argv = [sys.argv[1]] + sys.argv[2:]
runpy.run_path(sys.argv[0], run_name="__main__")
