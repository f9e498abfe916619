"""The pieces generated worlds are built of: rooms with doors, walled passages along a
bent centre line, and a field of clutter. Walls are ``Room.WALL`` thick and stand outside
the free space they bound, so a passage of width w measures w from wall face to wall
face."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from flylog.scene.spec import ObstacleConfig, ObstacleKind, TextureConfig


@dataclass(frozen=True)
class Room:
    """A rectangle of free space: centre, heading (rad), half length along the heading and
    half width across. Its doors are in the middle of its back and front walls."""

    centre: tuple[float, float]
    heading: float
    half_length: float
    half_width: float

    WALL = 0.1  # m, thickness of every generated wall

    def to_world(self, u: float, v: float) -> tuple[float, float]:
        c, s = math.cos(self.heading), math.sin(self.heading)
        return (self.centre[0] + c * u - s * v, self.centre[1] + s * u + c * v)

    def front_door(self) -> tuple[float, float]:
        """The middle of the front wall's inner face."""
        return self.to_world(self.half_length, 0.0)

    def inside(self, rng: np.random.Generator, keep: float) -> tuple[float, float]:
        """A point drawn uniformly at least ``keep`` + 0.35 m inside the walls."""
        room = keep + 0.35
        u = float(rng.uniform(-1, 1)) * max(self.half_length - room, 0.0)
        v = float(rng.uniform(-1, 1)) * max(self.half_width - room, 0.0)
        x, y = self.to_world(u, v)
        return (round(x, 3), round(y, 3))

    def samples(self, step: float = 0.2) -> np.ndarray:
        """(K, 2) points covering the room's floor."""
        us = np.linspace(-self.half_length, self.half_length, 2 + int(2 * self.half_length / step))
        vs = np.linspace(-self.half_width, self.half_width, 2 + int(2 * self.half_width / step))
        return np.array([self.to_world(u, v) for u in us for v in vs])


def _wall(
    a: tuple[float, float], b: tuple[float, float], texture: TextureConfig, height: float
) -> ObstacleConfig:
    return ObstacleConfig(
        kind=ObstacleKind.WALL,
        start=(round(a[0], 3), round(a[1], 3)),
        end=(round(b[0], 3), round(b[1], 3)),
        thickness=Room.WALL,
        height=height,
        texture=texture,
    )


def room_walls(
    room: Room,
    door_width: float,
    doors: tuple[bool, bool],
    texture: TextureConfig,
    height: float,
) -> list[ObstacleConfig]:
    """The four walls round ``room``, the back and front ones split by a door
    ``door_width`` wide where ``doors`` (back, front) says so. A wall's end caps (half its
    thickness) close the corners."""
    t = Room.WALL / 2
    hl, hw = room.half_length + t, room.half_width + t
    out = [
        _wall(room.to_world(-hl, hw), room.to_world(hl, hw), texture, height),
        _wall(room.to_world(-hl, -hw), room.to_world(hl, -hw), texture, height),
    ]
    for u, door in ((-hl, doors[0]), (hl, doors[1])):
        if not door:
            out.append(_wall(room.to_world(u, -hw), room.to_world(u, hw), texture, height))
            continue
        edge = door_width / 2 + t  # the cap ends the piece at the door's edge
        if hw - edge > 1e-6:
            out.append(_wall(room.to_world(u, edge), room.to_world(u, hw), texture, height))
            out.append(_wall(room.to_world(u, -hw), room.to_world(u, -edge), texture, height))
    return out


def passage_walls(
    line: np.ndarray,
    width: float,
    texture: TextureConfig,
    height: float,
    *,
    block_leg: int = -1,
    rng: np.random.Generator | None = None,
) -> list[ObstacleConfig]:
    """The two side walls of a passage ``width`` wide (face to face) along the centre line
    (K, 2), which runs from the outer face of one room's wall to that of the next: mitred
    at the bends, reaching through both rooms' walls. With ``block_leg`` k >= 1, a wall
    across leg k (from point k-1 to k) at a point drawn from ``rng`` closes the passage."""
    t = Room.WALL
    d = np.diff(line, axis=0)
    d /= np.hypot(d[:, 0], d[:, 1])[:, None]
    normals = np.stack([-d[:, 1], d[:, 0]], axis=1)
    offset = width / 2 + t / 2
    # the walls reach back through the first room's wall and on through the last's
    ends = [line[0] - d[0] * t / 2, line[-1] + d[-1] * t / 2]
    out = []
    for side in (1.0, -1.0):
        pts = [ends[0] + side * offset * normals[0]]
        for k in range(1, len(line) - 1):
            n = normals[k - 1] + normals[k]
            n /= np.hypot(*n)
            cos_half = float(np.dot(n, normals[k]))
            pts.append(line[k] + side * offset / cos_half * n)
        pts.append(ends[1] + side * offset * normals[-1])
        for a, b in itertools.pairwise(pts):
            out.append(
                _wall((float(a[0]), float(a[1])), (float(b[0]), float(b[1])), texture, height)
            )
    if block_leg >= 1:
        assert rng is not None
        a, b = line[block_leg - 1], line[block_leg]
        mid = a + float(rng.uniform(0.3, 0.7)) * (b - a)
        n = normals[block_leg - 1] * (width / 2 + t / 2)
        p, q = mid + n, mid - n
        out.append(_wall((float(p[0]), float(p[1])), (float(q[0]), float(q[1])), texture, height))
    return out


def clutter_field(
    rng: np.random.Generator,
    field: tuple[float, float, float, float],
    per_square_metre: float,
    keep: list[tuple[float, float]],
    texture: Callable[[np.random.Generator], TextureConfig],
    height: Callable[[np.random.Generator], float],
) -> list[ObstacleConfig]:
    """Boxes, cylinders and short walls at uniform positions in ``field`` (xmin, ymin,
    xmax, ymax), ``per_square_metre`` of them (fewer if 100 draws each do not place them),
    none within 1 m (plus its size) of the
    points ``keep``. They may touch and clump: the path check decides if a way is left."""
    x0, y0, x1, y1 = field
    count = round(per_square_metre * (x1 - x0) * (y1 - y0))
    out: list[ObstacleConfig] = []
    for _ in range(100 * count):
        if len(out) == count:
            break
        centre = (round(float(rng.uniform(x0, x1)), 3), round(float(rng.uniform(y0, y1)), 3))
        kind = rng.uniform()
        tex, h = texture(rng), round(float(rng.uniform(0.5, 1.0)) * height(rng), 2)
        if kind < 0.4:
            r = round(float(rng.uniform(0.1, 0.3)), 3)
            ob = ObstacleConfig(
                kind=ObstacleKind.CYLINDER, center=centre, radius=r, height=h, texture=tex
            )
            reach = r
        elif kind < 0.85:
            size = (round(float(rng.uniform(0.2, 0.6)), 3), round(float(rng.uniform(0.2, 0.6)), 3))
            yaw = round(float(rng.uniform(0.0, 180.0)), 1)
            ob = ObstacleConfig(
                kind=ObstacleKind.BOX, center=centre, size=size, yaw_deg=yaw, height=h, texture=tex
            )
            reach = math.hypot(*size) / 2
        else:
            half = float(rng.uniform(0.3, 0.75))
            yaw = float(rng.uniform(0.0, math.pi))
            a = (centre[0] - half * math.cos(yaw), centre[1] - half * math.sin(yaw))
            b = (centre[0] + half * math.cos(yaw), centre[1] + half * math.sin(yaw))
            ob = _wall(a, b, tex, h)
            reach = half
        if min(math.dist(centre, p) for p in keep) < 1.0 + reach:
            continue
        out.append(ob)
    return out
