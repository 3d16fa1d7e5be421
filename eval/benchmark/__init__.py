"""The paper's tracking benchmark (Sec. 4, Tables 6-8): subsequence protocol, tracker protocol and
runner, external CSV results, scoring with ``ycbvss.eval``'s metrics, ranking tables and curves.

    from ycbvss.eval.benchmark import (ProtocolOptions, load_sequences, make_protocol, run_benchmark,
                                       score_benchmark, write_report)
    seqs, info = load_sequences("ycbv_root")                 # GT + cameras only
    cfg = make_protocol(seqs, info, ProtocolOptions("ycbv", seed=0), models)
"""
from .protocol import (SCHEMA_DOC, VERSION, ProtocolOptions, check_config, frame_K, init_pose, make_protocol,
                       protocol_stats, read_config, summary_text)
from .report import ranking_csv, ranking_latex, ranking_markdown, write_report
from .results import HEADER as RESULTS_HEADER
from .results import format_results, read_result_dir, read_results, write_results
from .run import StaticTracker, TrackFrame, Tracker, run_benchmark
from .score import GtIndex, TrackerScores, gt_index, score_benchmark, score_tracker
from .sources import Sequence, detect_layout, load_models, load_scene, load_sequences

__all__ = [
    "SCHEMA_DOC", "VERSION", "ProtocolOptions", "check_config", "frame_K", "init_pose", "make_protocol",
    "protocol_stats", "read_config", "summary_text", "ranking_csv", "ranking_latex", "ranking_markdown",
    "write_report", "RESULTS_HEADER", "format_results", "read_result_dir", "read_results", "write_results",
    "StaticTracker", "TrackFrame", "Tracker", "run_benchmark", "GtIndex", "TrackerScores", "gt_index",
    "score_benchmark", "score_tracker", "Sequence", "detect_layout", "load_models", "load_scene",
    "load_sequences",
]
