"""refine.templates.texture_mode: which renderer get_renderer() serves, and RefineOptions.template_srgb_textures."""
import numpy as np
import pytest

from ycbvss.errors import YcbvssError
from ycbvss.refine.templates import get_renderer, texture_mode


def test_texture_mode_scopes_the_renderer_and_restores_it():
    plain = get_renderer()
    assert plain.srgb_textures is False
    with texture_mode(True):
        lin = get_renderer()
        assert lin.srgb_textures is True and lin is not plain
        assert get_renderer() is lin                     # one renderer per mode and process
        with texture_mode(False):
            assert get_renderer() is plain
        assert get_renderer() is lin
    assert get_renderer() is plain
    with pytest.raises(RuntimeError):
        with texture_mode(True):
            raise RuntimeError("inside")
    assert get_renderer() is plain                       # restored after an exception too


def test_refine_scene_rejects_a_non_bool_template_srgb_textures():
    from ycbvss.procedural.scene import make_scene
    from ycbvss.refine.bundle import RefineOptions, refine_scene

    ps = make_scene(seed=0, n_frames=2, width=160, height=120)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    imgs = {f.im_id: np.zeros((120, 160, 3), np.uint8) for f in ps.frames}
    with pytest.raises(YcbvssError, match="template_srgb_textures"):
        refine_scene(ps, ps.models, gt, RefineOptions(template_srgb_textures="yes"), images=imgs)
