"""YCBV-SS synthesis: real YCB-V frames with every object re-rendered at known poses (Blender Cycles in
worker processes), colour-matched and noised, written as a BOP dataset with exact GT.

Entry points: :func:`ycbvss.synth.run.run_synth` (``ycbvss synth``), :func:`ycbvss.synth.preview.write_preview`
(``ycbvss synth preview``) and :func:`ycbvss.synth.blender.render_job` (Blender rendering for other stages).
"""
