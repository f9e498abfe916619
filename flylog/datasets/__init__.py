"""``flylog import``: stereo datasets in their published layouts → ordinary flylog logs.

One module per layout (:mod:`~flylog.datasets.middlebury`, :mod:`~flylog.datasets.kitti`)
reads a folder into :class:`~flylog.datasets.logwrite.DatasetFrame` records and a rig;
:mod:`~flylog.datasets.logwrite` writes them as the contract's topics with the ground truth
under ``/truth/``; :mod:`~flylog.datasets.run` chooses the layout and the outputs.
"""
