"""pipeline.datasets.enlarged_model_scales: a YCBV-SS root (synth_report.json) is recognised, so the
pipeline leaves the table contact off on its enlarged models."""
import json

from ycbvss.pipeline.datasets import enlarged_model_scales


def test_scales_above_one_are_read_from_the_synthesis_report(tmp_path):
    (tmp_path / "synth_report.json").write_text(json.dumps(
        {"objects": {"1": {"scale": 1.02}, "5": {"scale": 1.045}, "7": {"scale": 1.0}, "9": {"scale": "x"}}}))
    assert enlarged_model_scales(tmp_path) == {1: 1.02, 5: 1.045}


def test_a_dataset_without_a_synthesis_report_has_no_enlarged_models(tmp_path):
    assert enlarged_model_scales(tmp_path) == {}
    (tmp_path / "synth_report.json").write_text(json.dumps({"objects": []}))
    assert enlarged_model_scales(tmp_path) == {}
