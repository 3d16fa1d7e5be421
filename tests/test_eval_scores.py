"""AUC / SR scores, GT-estimate matching, evaluate_arrays and the table writers. Budget: < 5 s."""
from __future__ import annotations

import csv
import io
import warnings

import numpy as np
import pytest

from ycbvss.eval.evaluate import EstArrays, EvalOptions, GtArrays, evaluate_arrays
from ycbvss.eval.matching import match
from ycbvss.eval.outputs import result_error_table
from ycbvss.eval.scores import accuracy_curve, auc, object_scores, overall_scores, success_rate
from ycbvss.eval.tables import ablation_table, error_table, to_csv, to_latex, to_markdown
from ycbvss.geometry.so3 import exp_so3
from ycbvss.scene import ObjectModel

K = np.array([[1000.0, 0, 320], [0, 1000.0, 240], [0, 0, 1]])


def test_auc_hand_computed_and_missing():
    assert abs(auc([0.0, 50.0, 100.0, np.inf], 100.0) - 37.5) < 1e-12
    assert abs(auc([5.0, np.nan], 10.0) - 25.0) < 1e-12              # NaN = missing = failed
    assert auc([np.inf, np.nan, np.inf], 100.0) == 0.0                  # all missing -> 0
    # AUC is the normalised area under the accuracy curve
    e = np.random.default_rng(0).exponential(20.0, 500)
    thr = np.linspace(0, 100, 20001)
    area = np.trapz(accuracy_curve(e, thr), thr) / 100.0
    assert abs(area - auc(e, 100.0)) < 0.05


def test_success_rate_thresholds():
    te = np.array([10.0, 49.9, 50.0, 10.0, np.nan])
    r = np.array([1.0, 4.9, 1.0, 5.0, 1.0])
    assert abs(success_rate(te, r) - 40.0) < 1e-12                     # strict < 5 cm and < 5 deg


def test_overall_is_mean_over_objects():
    per = {1: object_scores({"add_s_mm": np.array([0.0, 0.0, 0.0, 0.0]), "prj_px": np.zeros(4),
                             "te_mm": np.zeros(4), "r_deg": np.zeros(4)}),
           2: object_scores({"add_s_mm": np.array([np.inf]), "prj_px": np.array([np.inf]),
                             "te_mm": np.array([np.nan]), "r_deg": np.array([np.nan])})}
    o = overall_scores(per)
    assert abs(o["add_auc"] - 50.0) < 1e-12 and abs(o["add_prj_auc"] - 50.0) < 1e-12
    assert per[2]["n_missing"] == 1 and abs(o["sr_5cm5deg"] - 50.0) < 1e-12


def test_match_greedy_by_score_to_lowest_error():
    # one image, two instances of obj 5; estimate 0 (score .9) is closest to GT 1
    gt = dict(gt_scene=[1, 1, 1], gt_im=[1, 1, 2], gt_obj=[5, 5, 5])
    C = {0: [9.0, 1.0], 1: [2.0, 3.0]}                    # est -> cost per GT (0, 1)

    def cost(g, e):
        return np.array([[C[j][i] for i in g] for j in e])

    m = match(**gt, est_scene=[1, 1, 1, 1, 7], est_im=[1, 1, 2, 2, 1], est_obj=[5, 5, 5, 5, 5],
              est_score=[0.9, 0.5, 0.2, 0.8, 1.0], cost=cost)
    assert m.est_for_gt.tolist() == [1, 0, 3]              # GT2 gets the higher-scored estimate 3
    assert m.n_est_no_image == 1 and m.n_est_surplus == 1 and m.n_groups_surplus == 1


def _model(obj_id, pts, **kw):
    m = ObjectModel(obj_id=obj_id, name=f"{obj_id:03d}_thing", **kw)
    m.__dict__["vertices_mm"] = np.asarray(pts, dtype=np.float64)     # cached_property override
    return m


def test_evaluate_arrays_duplicates_missing_and_scores():
    rng = np.random.default_rng(5)
    pts = rng.normal(size=(300, 3)) * 30.0
    models = {1: _model(1, pts, textureless=True), 13: _model(13, pts)}
    Rg = exp_so3(rng.normal(size=(4, 3)))
    tg = np.array([[0, 0, 700.0], [10, 0, 800.0], [0, 20, 900.0], [5, 5, 600.0]])
    gt = GtArrays(np.array([1, 1, 1, 1]), np.array([1, 2, 3, 1]), np.array([1, 1, 1, 13]),
                  np.array([0, 0, 0, 1]), Rg, tg, np.broadcast_to(K, (4, 3, 3)).copy())
    # est for GT0: +10 mm in x (score .9) and a worse duplicate (score .1); GT1: exact; GT2: none
    est = EstArrays(np.array([1, 1, 1, 1, 9]), np.array([1, 1, 2, 1, 1]), np.array([1, 1, 1, 13, 1]),
                    np.array([0.9, 0.1, 1.0, 1.0, 1.0]), Rg[[0, 0, 1, 3, 0]],
                    tg[[0, 0, 1, 3, 0]] + np.array([[10.0, 0, 0], [90, 0, 0], [0, 0, 0], [0, 0, 4], [0, 0, 0]]))
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = evaluate_arrays(gt, est, models, EvalOptions())
    msgs = " ".join(str(x.message) for x in w)
    assert "1 estimate(s) for images not in the GT" in msgs and "highest-scored" in msgs
    e = res.errors
    assert abs(e["tx_mm"][0] - 10.0) < 1e-9 and abs(e["add_mm"][0] - 10.0) < 1e-9
    assert np.isnan(e["add_mm"][2]) and np.isnan(e["prj_px"][2])       # missing estimate
    assert e["symmetric"].tolist() == [0, 0, 0, 1]
    assert abs(e["add_s_mm"][3] - e["adds_mm"][3]) < 1e-12 and e["adds_mm"][3] <= 4.0 + 1e-9
    # obj 1: ADD(-S) errors 10, 0, inf -> AUC (90 + 100 + 0) / 3
    assert abs(res.per_object[1]["add_auc"] - 190.0 / 3) < 1e-9
    assert abs(res.summary["add_auc"] - (190.0 / 3 + res.per_object[13]["add_auc"]) / 2) < 1e-9
    assert res.summary["counts"]["n_gt_missing"] == 1
    md = to_markdown(result_error_table(res))
    assert r"001_thing\*" in md and "| all |" in md


def test_tables_render_paper_layouts():
    per = {11: {"mean_tx_mm": 0.39, "mean_ty_mm": 0.31, "mean_tz_mm": 0.88, "mean_r_deg": 0.40,
                "mean_prj_px": 0.71},
           2: {"tx_mm": 0.28, "ty_mm": 0.17, "tz_mm": 1.11, "r_deg": 0.31, "prj_px": 0.50}}
    names = {2: "002_master_chef_can", 11: "011_banana"}
    t = error_table(per, names, {11: True}, all_row={"tx_mm": 0.3, "ty_mm": 0.2, "tz_mm": 1.0, "r_deg": 0.3,
                                                     "prj_px": 0.6},
                    extra_rows=[("YCBV original", {"tx_mm": 3.03, "ty_mm": 2.15, "tz_mm": 21.4, "r_deg": 3.27,
                                                    "prj_px": None})])
    assert [r.label for r in t.rows] == ["002_master_chef_can", "011_banana", "all", "YCBV original"]
    tex = to_latex(t)
    assert r"011\_banana$^*$ & 0.39 & 0.31 & 0.88 & 0.40 & 0.71 \\" in tex
    assert tex.count(r"\midrule") == 2 and r"\toprule" in tex and r"\bottomrule" in tex
    assert "21.40 & 3.27 & - \\\\" in tex
    rows = list(csv.reader(io.StringIO(to_csv(t))))
    assert rows[0][:6] == ["object", "tx (mm)", "ty (mm)", "tz (mm)", "R (deg)", "PRJ (px)"]
    assert abs(float(rows[2][3]) - 0.88) < 1e-12 and rows[2][-1] == "1" and rows[4][5] == ""
    ab = ablation_table([("w/o f_edge", {"tx_mm": 0.29, "ty_mm": 0.25, "tz_mm": 1.40, "r_deg": 0.29, "prj_px": 0.51}),
                         ("using all", {"tx_mm": 0.28, "ty_mm": 0.22, "tz_mm": 0.85, "r_deg": 0.23, "prj_px": 0.46})])
    md = to_markdown(ab)
    assert "| using all | **0.28** | **0.22** | **0.85** | **0.23** | **0.46** |" in md
    assert r"\textbf{0.85}" in to_latex(ab)
    # ties are judged as printed (both 0.13 bold at 2 digits), but the CSV keeps the measured values
    tie = ablation_table([("w/o f_t", {"tx_mm": 0.0141, "ty_mm": 0.02, "tz_mm": 0.1262, "r_deg": 0.05, "prj_px": 0.05}),
                          ("using all", {"tx_mm": 0.0162, "ty_mm": 0.02, "tz_mm": 0.1314, "r_deg": 0.05, "prj_px": 0.05})])
    assert "| using all | 0.02 | **0.02** | **0.13** |" in to_markdown(tie)
    assert "| w/o f_t | **0.01** | **0.02** | **0.13** |" in to_markdown(tie)
    tie_rows = list(csv.reader(io.StringIO(to_csv(tie))))
    assert abs(float(tie_rows[2][3]) - 0.1314) < 1e-9 and abs(float(tie_rows[1][1]) - 0.0141) < 1e-9
    # counts (ints) print without decimals in every format; floats keep the table's digits
    from ycbvss.eval.tables import Row, Table
    cnt = Table(columns=["poses", "share"], rows=[Row("long", [4153, 1.0])], digits=3)
    assert "| long | 4153 | 1.000 |" in to_markdown(cnt) and r"long & 4153 & 1.000 \\" in to_latex(cnt)
    assert list(csv.reader(io.StringIO(to_csv(cnt))))[1][:3] == ["long", "4153", "1"]


def test_options_validation():
    from ycbvss.errors import YcbvssError
    with pytest.raises(YcbvssError):
        EvalOptions(add_bound_mm=0)
    with pytest.raises(YcbvssError):
        EvalOptions(adds_for="some")


def test_evaluate_arrays_no_estimates_scores_zero():
    rng = np.random.default_rng(6)
    models = {1: _model(1, rng.normal(size=(50, 3)) * 20.0)}
    gt = GtArrays(np.array([1, 1]), np.array([1, 2]), np.array([1, 1]), np.array([0, 0]),
                  np.stack([np.eye(3)] * 2), np.array([[0, 0, 500.0], [0, 0, 600.0]]),
                  np.broadcast_to(K, (2, 3, 3)).copy())
    res = evaluate_arrays(gt, EstArrays.from_estimates([]), models)
    s = res.summary
    assert s["add_auc"] == 0.0 and s["prj_auc"] == 0.0 and s["sr_5cm5deg"] == 0.0
    assert s["counts"]["n_gt_missing"] == 2 and np.all(np.isnan(res.errors["add_mm"]))


def test_evaluate_use_symmetries_continuous_axis():
    a = np.radians(np.arange(0, 360, 2.0))
    pts = np.concatenate([np.stack([60 * np.cos(a), 60 * np.sin(a), np.full_like(a, z)], 1)
                          for z in (-30.0, 0.0, 30.0)])
    m = _model(13, pts, diameter_mm=140.0, symmetries_continuous=[{"axis": [0, 0, 1], "offset": [0, 0, 0]}])
    Rg = exp_so3(np.array([[0.4, -0.2, 0.3]]))
    tg = np.array([[0.0, 0.0, 700.0]])
    gt = GtArrays(np.array([1]), np.array([1]), np.array([13]), np.array([0]), Rg, tg, K[None].copy())
    Re = Rg @ exp_so3(np.array([0, 0, np.radians(40.0)]))      # turned about the symmetry axis
    est = EstArrays(np.array([1]), np.array([1]), np.array([13]), np.array([1.0]), Re, tg + [2.0, 0, 0])
    plain = evaluate_arrays(gt, est, {13: m}, EvalOptions(symmetric_obj_ids=()))
    sym = evaluate_arrays(gt, est, {13: m}, EvalOptions(symmetric_obj_ids=(), use_symmetries=True))
    assert abs(plain.errors["r_deg"][0] - 40.0) < 1e-6 and plain.errors["add_mm"][0] > 30.0
    assert sym.errors["r_deg"][0] < 360.0 / 315 / 2 + 1e-6                  # within the sampling step
    assert abs(sym.errors["tx_mm"][0] - 2.0) < 1e-6 and sym.errors["add_mm"][0] < 2.0 + 60 * np.radians(0.6)
