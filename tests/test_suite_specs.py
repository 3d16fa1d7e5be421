"""The validation suites' scene lists hold what the issue asks of them (pure: nothing is rendered)."""
from __future__ import annotations

from collections import Counter

import pytest

from ycbvss.pipeline.suite import SUITES, YCBV21, clips_of


def test_ycbv21_has_every_object_in_three_scenes_with_four_to_seven_each():
    n = Counter(o for s in YCBV21 for o in s.obj_ids)
    assert sorted(n) == list(range(1, 22)) and min(n.values()) >= 3, n
    assert all(4 <= len(s.obj_ids) <= 7 for s in YCBV21)


@pytest.mark.parametrize("suite", ["ycbv21-fresh", "ycbv21-fresh2", "ycbv21-fresh3"])
def test_fresh_scenes_are_sealed_new_and_cover_every_object_twice(suite):
    YCBV21_FRESH = SUITES[suite]
    n = Counter(o for s in YCBV21_FRESH for o in s.obj_ids)
    assert sorted(n) == list(range(1, 22)) and set(n.values()) == {2}, n
    assert all(s.held_out for s in YCBV21_FRESH)
    # no scene id or layout seed shared with another suite: their renders and layouts are new
    others = [s for name, specs in SUITES.items() if name != suite for s in specs]
    assert not {s.scene_id for s in YCBV21_FRESH} & {s.scene_id for s in others}
    assert not {s.seed for s in YCBV21_FRESH} & {s.seed for s in others}
    assert all(len(set(s.obj_ids)) == len(s.obj_ids) == 7 for s in YCBV21_FRESH)
    assert all({c.kind for c in clips_of(s)} == {"short", "medium"} for s in YCBV21_FRESH)


@pytest.mark.parametrize("suite", ["ycbv21-long2", "ycbv21-long3", "ycbv21-long4"])
def test_sealed_long_scenes_are_new_and_cover_every_object_once(suite):
    specs = SUITES[suite]
    n = Counter(o for s in specs for o in s.obj_ids)
    assert sorted(n) == list(range(1, 22)) and set(n.values()) == {1}, n
    assert all(s.held_out and s.is_long and s.arc_deg >= 45.0 for s in specs)
    others = [s for name, sp in SUITES.items() if name != suite for s in sp]
    assert not {s.scene_id for s in specs} & {s.scene_id for s in others}
    assert not {s.seed for s in specs} & {s.seed for s in others}
    assert all({c.kind for c in clips_of(s)} == {"short", "medium", "long"} for s in specs)


def test_code_fingerprint_follows_the_code_not_its_comments_or_docstrings(tmp_path):
    from ycbvss.pipeline.suite import code_fingerprint

    a = tmp_path / "gen.py"
    a.write_text('"""Module doc."""\ndef f(x):\n    """Doc."""\n    return x + 1  # one\n')
    base = code_fingerprint([a])
    a.write_text('"""Another module doc."""\n# a comment\ndef f(x):\n    """Other doc."""\n    return x + 1\n')
    assert code_fingerprint([a]) == base
    a.write_text('"""Module doc."""\ndef f(x):\n    """Doc."""\n    return x + 2\n')
    assert code_fingerprint([a]) != base


def test_every_generator_module_exists_and_enters_the_cache_key(monkeypatch):
    import ycbvss.pipeline.suite as S

    key = S.spec_hash(YCBV21[0], 640, 480, 12)
    assert key == S.spec_hash(YCBV21[0], 640, 480, 12)
    assert key != S.spec_hash(YCBV21[0], 640, 480, 16) and key != S.spec_hash(YCBV21[1], 640, 480, 12)
    monkeypatch.setattr(S, "generator_fingerprint", lambda: "another generator")
    assert S.spec_hash(YCBV21[0], 640, 480, 12) != key
