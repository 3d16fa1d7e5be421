"""Session 95: the tables of record with today's defaults (session 94's black-object edges on), all
from rows refined on one host's renders of the ycbv21 suite.

Runs that today's code changes did not touch are reused: a scene without a black object (the two
clamps) refines bit for bit as before session 94, so long-2 and short/medium scenes 2, 4 and 9 come
from the session 93/94 "before" rows. Everything else was refined with today's defaults.

    python bench/records_s95.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full

writes ``bench/results/ycbv21/s95/rows/*.csv.gz`` (the assembled sets, if the session's new row
files are given with ``--new-long-p0`` / ``--new-sm-p15``) and the report tables of each set
(``suite_runs.py report``): ``s95/long_seeds05/``, ``s95/bias_long_seed0/`` and
``s95/short_medium_seeds015/``.
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


def assemble(new_long_p0: Path | None, new_sm_p15: Path | None) -> dict[str, list[Path]]:
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
    return {
        "long_seeds05": [S95 / "s95_long_paper_seed0.csv.gz", S94 / "s94_long13_paper_seed5_linear_contrast.csv.gz", l2_p5],
        "bias_long_seed0": [S94 / "s94_long1_gt_seed0_linear_contrast.csv.gz", l2_gt,
                            S94 / "s94_long3_gt_seed0_linear_contrast.csv.gz"],
        "short_medium_seeds015": [sm0, S94 / "s94_short_medium_scenes138_paper_seed0_after.csv.gz", dev,
                                  S95 / "s95_short_medium_paper_seeds15.csv.gz"],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--new-long-p0", type=Path, help="rows.csv of long 1-3, paper init, seed 0 (this session)")
    ap.add_argument("--new-sm-p15", type=Path, help="rows.csv of short/medium 1-9, paper init, seeds 1 and 5")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(HERE))
    import suite_runs

    for name, files in assemble(a.new_long_p0, a.new_sm_p15).items():
        missing = [str(f) for f in files if not f.is_file()]
        if missing:
            print(f"{name}: skipped, missing {missing}")
            continue
        suite_runs.main(["report", "--dataset", a.dataset, "--suite-root", a.suite_root,
                         "--rows", *map(str, files), "--out", str(RES / "s95" / name)])
    return 0


if __name__ == "__main__":
    sys.exit(main())
