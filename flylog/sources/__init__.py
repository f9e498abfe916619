"""flylog.sources: what an input gives, whatever its format (a flylog log, an imported
dataset's log, a ROS 2 bag): :func:`input_at` decides the format once, and its
:class:`Input` gives the replay source, the ground truth and the trajectories.

- ``door``: :func:`input_at`, :class:`Input`, :class:`InputFormat`.
- ``inputs``: :class:`ReplayInputs`, what replay needs of a flylog log before streaming it.
- ``stream``: :class:`ReplaySource`, the inputs and the paired record stream.
- ``truth``: :class:`LogTruth` and a flylog log's truth and trajectories; ``bag``: a bag's.
- ``trajectory``: :class:`Trajectory`, planar poses at log times.
"""

from flylog.sources.door import Input, InputFormat, input_at, read_truth

__all__ = ["Input", "InputFormat", "input_at", "read_truth"]
