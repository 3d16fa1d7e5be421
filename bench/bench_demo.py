"""Benchmark `ycbvss demo`: wall-clock per stage, refined vs initial errors, machine load.

    python bench/bench_demo.py                 # the default demo (24 frames, 640x480, Blender, ablations)
    python bench/bench_demo.py --quick         # the CI-sized run
    python bench/bench_demo.py --renderer fast --no-ablation

Target (issue 5): the default demo under 3 minutes on 2 cores; --quick under 60 s. The load
average is printed because other processes on a shared machine inflate every figure.
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--renderer", default="blender", choices=("blender", "fast"))
    ap.add_argument("--no-ablation", dest="ablation", action="store_false")
    ap.add_argument("--frames", type=int, default=None)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    os.environ.setdefault("YCBVSS_NO_PROGRESS", "1")
    from ycbvss.pipeline.demo import DemoOptions, run_demo
    from ycbvss.pipeline.validate import Stages

    out = a.out or Path(tempfile.mkdtemp(prefix="ycbvss_bench_demo_"))
    load0 = os.getloadavg()
    st = Stages(quiet=True)
    s = run_demo(DemoOptions(out=out, quick=a.quick, renderer=a.renderer, ablation=a.ablation, frames=a.frames), st)
    total = st.total_s
    print(f"cores: {os.cpu_count()}, load average before: {load0[0]:.1f}, after: {os.getloadavg()[0]:.1f}")
    print(f"demo ({'quick' if a.quick else 'default'}, renderer {a.renderer}, ablation {a.ablation}): "
          f"{s['frames']} frames, {s['pairs']} pairs")
    cores = os.cpu_count() or 1
    est = 0.0
    print(f"  {'stage':<45s} {'wall':>7s}   CPU: {'main':>6s} {'children':>8s}   idle estimate")
    for k, v in st.times.items():
        c_main, c_child = st.cpu.get(k, (0.0, 0.0))
        # main process and children (Blender workers / the ablation process) run concurrently
        e = max(c_main, (c_main + c_child) / cores)
        est += e
        print(f"  {k:<45s} {v:7.1f} s      {c_main:6.1f} {c_child:8.1f}   {e:6.1f} s")
    print(f"  {'total':<45s} {total:7.1f} s   idle-machine estimate (sum of max(main, all CPU / {cores} cores)): "
          f"{est:.0f} s")
    i, r = s["initial"], s["refined"]
    print(f"initial: ADD {i['achieved_add_mm']:.2f} mm, PRJ {i['achieved_prj_px']:.2f} px; "
          f"refined: ADD {r['add_mm']:.3f} mm, PRJ {r['prj_px']:.3f} px, tz {r['tz_mm']:.3f} mm, R {r['r_deg']:.3f} deg")
    for v, m in s.get("variants_keyframes", {}).items():
        print(f"  {v:<12s} ADD {m['add_mm']:.3f} mm  PRJ {m['prj_px']:.3f} px")
    print(json.dumps({"total_s": round(total, 1), "stages_s": {k: round(v, 1) for k, v in st.times.items()}}))
    print(f"report: {s['report']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
