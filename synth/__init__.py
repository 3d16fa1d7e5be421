"""YCBV-SS synthesis: real YCB-V frames with every object re-rendered at known poses (Blender)."""
