"""Fast headless OpenGL rasteriser (moderngl, EGL) for masks, depth, gt_info and the refiner."""
