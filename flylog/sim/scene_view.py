"""The scene as Foxglove primitives (``/truth/scene``), for viewing only."""

from __future__ import annotations

import math

from flylog.io.records import BoxShape, CylinderShape
from flylog.scene.load import Scene
from flylog.scene.spec import ObstacleKind


def scene_shapes(scene: Scene) -> list[BoxShape | CylinderShape]:
    """One primitive per obstacle (walls as thin boxes), coloured like its texture."""
    shapes: list[BoxShape | CylinderShape] = []
    for i, ob in enumerate(scene.obstacles):
        colour = (*ob.texture.color, 1.0)
        h = ob.height
        if ob.kind is ObstacleKind.CYLINDER:
            assert ob.center is not None and ob.radius is not None
            shapes.append(
                CylinderShape(f"obstacle_{i}", (*ob.center, h / 2), 2 * ob.radius, h, colour)
            )
        elif ob.kind is ObstacleKind.BOX:
            assert ob.center is not None and ob.size is not None
            shapes.append(
                BoxShape(
                    f"obstacle_{i}",
                    (*ob.center, h / 2),
                    (*ob.size, h),
                    math.radians(ob.yaw_deg),
                    colour,
                )
            )
        else:
            assert ob.start is not None and ob.end is not None
            (x0, y0), (x1, y1) = ob.start, ob.end
            length = math.hypot(x1 - x0, y1 - y0)
            shapes.append(
                BoxShape(
                    f"obstacle_{i}",
                    ((x0 + x1) / 2, (y0 + y1) / 2, h / 2),
                    (length, ob.thickness, h),
                    math.atan2(y1 - y0, x1 - x0),
                    colour,
                )
            )
    return shapes
