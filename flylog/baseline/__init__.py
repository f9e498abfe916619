"""flylog.baseline: conventional stereo (OpenCV StereoSGBM) to compare the flies against.

The engine is in :mod:`flylog.baseline.sgbm` (it imports OpenCV; this package does not)::

    from flylog.baseline.sgbm import SgbmEngine

    engine = SgbmEngine(SgbmConfig(), StereoRig(), points=5000)
    engine.set_images(pair)
    stats = engine.step()
    cloud = engine.population  # xyz in base_link, fitness = texture confidence
"""

from flylog.baseline.config import SgbmConfig, SgbmMode

__all__ = ["SgbmConfig", "SgbmMode"]
