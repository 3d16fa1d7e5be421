"""Result tables from plain data, rendered as Markdown, CSV and LaTeX (booktabs).

Layouts of the paper:

- :func:`error_table` (Table 4): rows = object names (textureless marked ``*``), an ``all`` row,
  optional extra rows after a rule (e.g. ``initial``, reference rows); columns tx ty tz (mm),
  R (deg), PRJ (px) as MEAN errors.
- :func:`ablation_table` (Table 5): rows = configurations, same columns, best per column in bold.
- :func:`score_table`: per-object ADD(-S)-AUC, PRJ-AUC, ADD-PRJ-AUC, SR and the mean over objects.

Values are plain dicts keyed ``tx_mm ty_mm tz_mm r_deg prj_px`` (a ``mean_`` prefix is accepted);
a missing / None / NaN value renders as ``-``.
"""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

from ..io.atomic import write_text_atomic

ERROR_COLS = ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px")
ERROR_HEADERS = ("tx (mm)", "ty (mm)", "tz (mm)", "R (deg)", "PRJ (px)")
ERROR_LATEX = (r"tx\,{\scriptsize(mm)}", r"ty\,{\scriptsize(mm)}", r"tz\,{\scriptsize(mm)}",
               r"R\,{\scriptsize($^\circ$)}", r"PRJ\,{\scriptsize(px)}")
SCORE_COLS = ("add_auc", "prj_auc", "add_prj_auc", "sr")
SCORE_HEADERS = ("ADD(-S) AUC", "PRJ AUC", "ADD-PRJ-AUC", "SR")


@dataclass
class Row:
    label: str
    values: list                           # floats (ints: counts, printed without decimals) or None
    mark: bool = False                     # textureless: '*' after the label
    rule_before: bool = False              # horizontal rule above this row
    bold: list[bool] | None = None


@dataclass
class Table:
    columns: list[str]
    rows: list[Row] = field(default_factory=list)
    label_header: str = ""
    latex_columns: list[str] | None = None
    caption: str = ""
    digits: int = 2


def _get(d: dict, k: str):
    v = d.get(k, d.get(f"mean_{k}"))
    if v is None:
        return None
    v = float(v)
    return None if math.isnan(v) else v


def _fmt(v, digits: int) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    if isinstance(v, int) and not isinstance(v, bool):
        return str(v)
    if math.isinf(v):
        return "inf"
    return f"{v:.{digits}f}"


def error_table(per_object: dict, names: dict | None = None, textureless: dict | None = None,
                all_row: dict | None = None, extra_rows: list[tuple[str, dict]] | None = None,
                caption: str = "", digits: int = 2) -> Table:
    """Paper Table 4 layout. ``per_object``: obj_id -> dict of mean errors; ``names``: obj_id ->
    display name; ``textureless``: obj_id -> bool; ``all_row``: dict of mean errors (None: no row);
    ``extra_rows``: (label, dict) after a rule."""
    names, textureless = names or {}, textureless or {}
    t = Table(list(ERROR_HEADERS), label_header="object", latex_columns=list(ERROR_LATEX),
              caption=caption, digits=digits)
    for o in sorted(per_object):
        t.rows.append(Row(str(names.get(o, o)), [_get(per_object[o], k) for k in ERROR_COLS],
                          mark=bool(textureless.get(o, False))))
    if all_row is not None:
        t.rows.append(Row("all", [_get(all_row, k) for k in ERROR_COLS]))
    for i, (label, vals) in enumerate(extra_rows or []):
        t.rows.append(Row(label, [_get(vals, k) for k in ERROR_COLS], rule_before=i == 0))
    return t


def _bold_min(rows: list[Row], digits: int | None = None) -> None:
    """Bold each column's minimum; with ``digits``, compared as printed at that precision (ties
    bolded, as the paper does), the values themselves kept unrounded (the CSV carries them)."""
    def key(v: float) -> float:
        return v if digits is None else round(v, digits)

    ncol = max((len(r.values) for r in rows), default=0)
    for c in range(ncol):
        vals = [key(r.values[c]) for r in rows if c < len(r.values) and r.values[c] is not None]
        if not vals:
            continue
        best = min(vals)
        for r in rows:
            r.bold = r.bold or [False] * len(r.values)
            r.bold[c] = r.values[c] is not None and abs(key(r.values[c]) - best) < 1e-12
    return None


def ablation_table(configs: list[tuple[str, dict]], bold_best: bool = True, caption: str = "",
                   digits: int = 2) -> Table:
    """Paper Table 5 layout: one row per (configuration name, dict of mean errors)."""
    t = Table(list(ERROR_HEADERS), label_header="configuration", latex_columns=list(ERROR_LATEX),
              caption=caption, digits=digits)
    t.rows = [Row(label, [_get(vals, k) for k in ERROR_COLS]) for label, vals in configs]
    if bold_best:
        _bold_min(t.rows, digits)
    return t


def score_table(per_object: dict, overall: dict, names: dict | None = None,
                textureless: dict | None = None, caption: str = "", digits: int = 1) -> Table:
    """Per-object AUC / SR scores (percent) with a final ``all`` row (mean over objects)."""
    names, textureless = names or {}, textureless or {}
    t = Table(list(SCORE_HEADERS), label_header="object", caption=caption, digits=digits)
    for o in sorted(per_object):
        t.rows.append(Row(str(names.get(o, o)), [_get(per_object[o], k) for k in SCORE_COLS],
                          mark=bool(textureless.get(o, False))))
    t.rows.append(Row("all", [_get(overall, k) for k in SCORE_COLS], rule_before=True))
    return t


# ----------------------------------------------------------------------------- renderers
def to_markdown(t: Table) -> str:
    def label(r: Row) -> str:
        return r.label.replace("*", r"\*") + (r"\*" if r.mark else "")

    lines = ["| " + " | ".join([t.label_header] + list(t.columns)) + " |",
             "|" + "|".join([":---"] + ["---:"] * len(t.columns)) + "|"]
    for r in t.rows:
        cells = []
        for c, v in enumerate(r.values):
            s = _fmt(v, t.digits)
            cells.append(f"**{s}**" if r.bold and r.bold[c] and s != "-" else s)
        lines.append("| " + " | ".join([label(r)] + cells) + " |")
    out = "\n".join(lines) + "\n"
    return (f"{t.caption}\n\n" if t.caption else "") + out


def to_csv(t: Table) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([t.label_header or "row"] + list(t.columns) + ["textureless"])
    for r in t.rows:
        w.writerow([r.label] + ["" if v is None else f"{v:.6g}" for v in r.values] + [int(r.mark)])
    return buf.getvalue()


def _latex_escape(s: str) -> str:
    for a, b in (("\\", r"\textbackslash{}"), ("_", r"\_"), ("%", r"\%"), ("&", r"\&"), ("#", r"\#"),
                 ("$", r"\$"), ("{", r"\{"), ("}", r"\}")):
        s = s.replace(a, b)
    return s


def to_latex(t: Table) -> str:
    cols = t.latex_columns or [_latex_escape(c) for c in t.columns]
    lines = [r"\begin{table}", r"\centering", r"\small",
             r"\begin{tabular}{l" + "c" * len(cols) + "}", r"\toprule",
             " & ".join([_latex_escape(t.label_header)] + cols) + r" \\", r"\midrule"]
    for r in t.rows:
        if r.rule_before:
            lines.append(r"\midrule")
        cells = []
        for c, v in enumerate(r.values):
            s = _fmt(v, t.digits)
            cells.append(rf"\textbf{{{s}}}" if r.bold and r.bold[c] and s != "-" else s)
        lab = _latex_escape(r.label) + (r"$^*$" if r.mark else "")
        lines.append(" & ".join([lab] + cells) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}"]
    if t.caption:
        lines.append(r"\caption{" + _latex_escape(t.caption) + "}")
    lines.append(r"\end{table}")
    return "\n".join(lines) + "\n"


def write_table(t: Table, out_dir: str | Path, stem: str) -> list[Path]:
    """Write ``stem.md``, ``stem.csv``, ``stem.tex`` atomically into ``out_dir``."""
    out_dir = Path(out_dir)
    paths = []
    for ext, fn in (("md", to_markdown), ("csv", to_csv), ("tex", to_latex)):
        p = out_dir / f"{stem}.{ext}"
        write_text_atomic(p, fn(t))
        paths.append(p)
    return paths
