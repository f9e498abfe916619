"""flylog.baseline: conventional stereo (OpenCV StereoSGBM) to compare the flies against."""
