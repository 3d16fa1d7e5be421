"""ycbvss: YCB-Video / BOP toolkit for exact-ground-truth pose refinement research.

Conventions everywhere (as the BOP toolkit): OpenCV camera axes (x right, y down, z forward),
poses are object-to-camera rigid transforms stored as 4x4 float64 matrices ``T`` with the
translation in millimetres, images are HxW(xC) numpy arrays, depth is in millimetres unless a
name says otherwise.
"""
__version__ = "0.1.0"
