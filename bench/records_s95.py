"""Session 95: the tables of record with today's defaults (session 94's black-object edges on), all
from rows refined on one host's renders of the ycbv21 suite.

Runs that today's code changes did not touch are reused: a scene without a black object (the two
clamps) refines bit for bit as before session 94, so long-2 and short/medium scenes 2, 4 and 9 come
from the session 93/94 "before" rows. Everything else was refined with today's defaults.

    python bench/records_s95.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --long4-root /tmp/suite/long4

writes ``bench/results/ycbv21/s95/rows/*.csv.gz`` (the assembled sets, if the session's new row
files are given with ``--new-long-p0`` / ``--new-sm-p15`` / ``--new-long4-after`` / ``--new-long4-before``) and the report tables of each set
(``suite_runs.py report``): ``s95/long_seeds05/``, ``s95/bias_long_seed0/`` and
``s95/short_medium_seeds015/``; and the sealed ``ycbv21-long4`` scenes 67 and 68 (the two with a clamp)
at seed 0 with today's defaults and without session 94's change (``edge_linear_dark`` 0), paired on
one host's renders: ``s95/long4_6768_seed0/`` and ``s95/long4_6768_seed0/paired.md``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent
RES = HERE / "results" / "ycbv21"
S93, S94, S95 = RES / "s93" / "rows", RES / "s94" / "rows", RES / "s95" / "rows"
BLACK_FREE_LONG = ("long-2",)          # long scenes without a clamp
BLACK_FREE_SCENES = (2, 4, 9)           # short / medium scenes without a clamp


def _read(p: Path) -> pd.DataFrame:
    return pd.read_csv(p, low_memory=False)


def _write(a: pd.DataFrame, name: str) -> Path:
    S95.mkdir(parents=True, exist_ok=True)
    p = S95 / name
    tmp = p.with_name(p.name + ".part")
    a.to_csv(tmp, index=False, compression={"method": "gzip", "mtime": 0})   # same bytes on a re-run
    tmp.replace(p)
    return p


def assemble(new_long_p0: Path | None, new_sm_p15: Path | None, new_l4_after: Path | None = None,
             new_l4_before: Path | None = None) -> dict[str, list[Path]]:
    """The row files of each set (writing the reused parts and, when given, the new rows into
    s95/rows)."""
    gt = _read(S93 / "s93_long_gt_seed0_rebuilt.csv.gz")
    p5 = _read(S93 / "s93_long_paper_seed5_all_woft.csv.gz")
    l2_gt = _write(gt[gt["clip"].isin(BLACK_FREE_LONG)], "s95_reused_long2_gt_seed0.csv.gz")
    l2_p5 = _write(p5[p5["clip"].isin(BLACK_FREE_LONG) & (p5["variant"] == "using all")],
                   "s95_reused_long2_paper_seed5.csv.gz")
    sm0 = _read(S94 / "s94_short_medium_scenes123489_paper_seed0_before.csv.gz")
    sm0 = _write(sm0[sm0["scene_id"].isin(BLACK_FREE_SCENES)], "s95_reused_short_medium_scenes249_paper_seed0.csv.gz")
    dev = _read(S94 / "s94_dev567_short_medium_seed0_linear_contrast.csv.gz")
    dev = _write(dev[dev["init"] == "paper"], "s95_reused_short_medium_scenes567_paper_seed0.csv.gz")
    if new_long_p0 is not None:
        _write(_read(new_long_p0), "s95_long_paper_seed0.csv.gz")
    if new_sm_p15 is not None:
        _write(_read(new_sm_p15), "s95_short_medium_paper_seeds15.csv.gz")
    for tag, f in (("after", new_l4_after), ("before", new_l4_before)):
        if f is not None:
            _write(_read(f), f"s95_long4_6768_paper_seed0_{tag}.csv.gz")
    return {
        "long_seeds05": [S95 / "s95_long_paper_seed0.csv.gz", S94 / "s94_long13_paper_seed5_linear_contrast.csv.gz", l2_p5],
        "bias_long_seed0": [S94 / "s94_long1_gt_seed0_linear_contrast.csv.gz", l2_gt,
                            S94 / "s94_long3_gt_seed0_linear_contrast.csv.gz"],
        "short_medium_seeds015": [sm0, S94 / "s94_short_medium_scenes138_paper_seed0_after.csv.gz", dev,
                                  S95 / "s95_short_medium_paper_seeds15.csv.gz"],
        "long4_6768_seed0": [S95 / "s95_long4_6768_paper_seed0_after.csv.gz"],
    }


COLS = ["tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px"]


def _fmt(v) -> str:
    return " / ".join(f"{x:.3f}" for x in v)


def paired_long4() -> str | None:
    """Markdown: the sealed long-67 and long-68 at seed 0 before -> after session 94's change, per clip
    over its objects and for each object (tx / ty / tz mm / R deg / PRJ px)."""
    fa, fb = S95 / "s95_long4_6768_paper_seed0_after.csv.gz", S95 / "s95_long4_6768_paper_seed0_before.csv.gz"
    if not (fa.is_file() and fb.is_file()):
        return None
    a, b = _read(fa), _read(fb)
    out = ["Sealed ycbv21-long4, long-67 and long-68 (each with one clamp), paper init, seed 0, one host's renders: "
           "without session 94's change (`edge_linear_dark` 0) -> today's defaults. tx / ty / tz mm / R deg / PRJ px, "
           "means per object over its 200 poses; per clip over its objects.", "",
           "| clip | object | before | after |", "|---|---|---|---|"]
    for clip in sorted(a["clip"].unique()):
        A, B = a[a["clip"] == clip], b[b["clip"] == clip]
        out.append(f"| {clip} | all | {_fmt(B.groupby('obj_id')[COLS].mean().mean())} | "
                   f"{_fmt(A.groupby('obj_id')[COLS].mean().mean())} |")
        for o in sorted(A["obj_id"].unique()):
            out.append(f"| {clip} | {o} | {_fmt(B[B.obj_id == o][COLS].mean())} | {_fmt(A[A.obj_id == o][COLS].mean())} |")
    out.append(f"| both | all | {_fmt(b.groupby(['clip', 'obj_id'])[COLS].mean().mean())} | "
               f"{_fmt(a.groupby(['clip', 'obj_id'])[COLS].mean().mean())} |")
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite-root", required=True, help="the ycbv21 suite rendered (scenes 1-9)")
    ap.add_argument("--long4-root", help="ycbv21-long4 rendered (scenes 67, 68); without it that set is skipped")
    ap.add_argument("--new-long-p0", type=Path, help="rows.csv of long 1-3, paper init, seed 0 (this session)")
    ap.add_argument("--new-sm-p15", type=Path, help="rows.csv of short/medium 1-9, paper init, seeds 1 and 5")
    ap.add_argument("--new-long4-after", type=Path, help="rows.csv of ycbv21-long4 67, 68, paper init, seed 0")
    ap.add_argument("--new-long4-before", type=Path, help="the same with edge_linear_dark 0")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(HERE))
    import suite_runs

    for name, files in assemble(a.new_long_p0, a.new_sm_p15, a.new_long4_after, a.new_long4_before).items():
        missing = [str(f) for f in files if not f.is_file()]
        if missing:
            print(f"{name}: skipped, missing {missing}")
            continue
        long4 = name.startswith("long4")
        if long4 and not a.long4_root:
            print(f"{name}: skipped, no --long4-root")
            continue
        # each set's own suite root and scenes: the report reads the scenes' visibility from them
        where = (["--suite-root", a.long4_root, "--suite", "ycbv21-long4", "--scenes", "67,68"] if long4
                 else ["--suite-root", a.suite_root])
        suite_runs.main(["report", "--dataset", a.dataset, *where, "--rows", *map(str, files),
                         "--out", str(RES / "s95" / name)])
    md = paired_long4()
    if md is not None:
        p = RES / "s95" / "long4_6768_seed0" / "paired.md"
        p.parent.mkdir(parents=True, exist_ok=True)
        tmp = p.with_name(p.name + ".part")
        tmp.write_text(md)
        tmp.replace(p)
        print(f"paired: {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
