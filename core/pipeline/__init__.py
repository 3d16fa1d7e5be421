"""The joined loops: `ycbvss validate` (synth -> perturb -> refine -> eval -> report) and `ycbvss demo`."""
