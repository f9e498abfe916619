"""Generated worlds: families of scenes drawn from a seed, each checked before it is used.

- ``passages``: rooms joined in a chain by ``passages`` passages (walled both sides, each of
  one width drawn from ``passage_width``, legs joined by bends drawn from ``bend_deg``);
  the rooms are closed but for their doors, so the passages are the only way.
- ``clutter``: a closed arena whose middle holds boxes, cylinders and short walls at
  ``density(difficulty)`` obstacles per square metre; the measured difficulty is the
  narrowest gap on the shortest path (twice its smallest clearance).
- ``dead-end``: a ``passages`` or a ``clutter`` world (the seed decides) with a wall across
  the way, so that no path reaches the goal.

Every world is checked on the footprint's grid (:mod:`flylog.scene.occupancy`): start and
goal free, a path exists (for ``dead-end``: none does; for every family the start's free
space is closed, so the robot cannot go round the outside), and the world fits the
planner's default grid. A world that fails is drawn again from the same generator.
Textures, heights, light and obstacle kinds vary with the seed.
"""

from __future__ import annotations

import enum
import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flylog.config import param
from flylog.errors import ConfigError
from flylog.scene.footprints import compile_footprints
from flylog.scene.occupancy import PathCheck, clearance_grid, shortest_path
from flylog.scene.spec import (
    GeneratedConfig,
    GroundConfig,
    LightingConfig,
    ObstacleConfig,
    ObstacleKind,
    RobotConfig,
    SceneSpec,
    TextureConfig,
)
from flylog.scene.world_parts import Room, clutter_field, passage_walls, room_walls
from flylog.sim.camera_defects import CameraDefects

# Worlds drawn per seed before giving up (a draw fails when its pieces overlap or its
# obstacles close the way); the families' defaults need 1-3 draws.
MAX_DRAWS = 200


class Family(enum.Enum):
    PASSAGES = "passages"
    CLUTTER = "clutter"
    DEAD_END = "dead-end"


@dataclass(frozen=True)
class GenerateConfig:
    """The families' parameters (metres and degrees)."""

    passages: tuple[int, int] = param((1, 3), help="passages: how many passages in a chain")
    passage_width: tuple[float, float] = param(
        (1.0, 1.8), help="passages: wall face to wall face", unit="m"
    )
    legs: tuple[int, int] = param((2, 3), help="passages: straight legs per passage")
    leg_length: tuple[float, float] = param((1.5, 3.0), help="passages: leg lengths", unit="m")
    bend_deg: tuple[float, float] = param(
        (30.0, 90.0), help="passages: size of a bend (either way)", unit="deg"
    )
    room_half: tuple[float, float] = param(
        (1.2, 1.8), help="passages: half sides of a room", unit="m"
    )
    difficulty: float = param(
        0.5,
        help="clutter: 0 (sparse) to 1 (dense): density 0.1 + 0.3 × this obstacles per m²",
        min=0.0,
        max=1.0,
    )
    arena_length: tuple[float, float] = param(
        (8.0, 11.0), help="clutter: start to goal along x", unit="m"
    )
    arena_width: tuple[float, float] = param((4.5, 6.0), help="clutter: arena width", unit="m")
    robot_radius: float = param(0.3, help="the robot's footprint radius", unit="m", min=0.0)
    margin: float = param(
        0.05,
        help="added to robot_radius for the path check (the planner's inflation_margin)",
        unit="m",
        min=0.0,
    )
    check_cell: float = param(0.05, help="cell of the path check's grid", unit="m", min=0.01)
    max_extent: float = param(
        19.0,
        help="every obstacle within half this of the start-goal midpoint (the planner's "
        "default grid is 20 m a side)",
        unit="m",
    )
    duration: float = param(150.0, help="the scene's duration", unit="s", min=1.0)

    def __post_init__(self) -> None:
        for name in ("passages", "passage_width", "legs", "leg_length", "bend_deg", "room_half"):
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi:
                msg = f"'{name}' must be 0 < min <= max, got {[lo, hi]}"
                raise ConfigError(msg)
        need = 2 * (self.robot_radius + self.margin)
        if self.passage_width[0] <= need:
            msg = (
                f"'passage_width' must exceed the checked footprint's diameter {need:g} m "
                f"(robot_radius and margin), got {list(self.passage_width)}"
            )
            raise ConfigError(msg)


@dataclass(frozen=True)
class World:
    """A checked world: its scene and the path check behind it."""

    spec: SceneSpec
    check: PathCheck


def generate_world(
    family: Family, seed: int, config: GenerateConfig, rng: np.random.Generator
) -> World:
    """Draw ``family``'s world from ``rng`` until one passes the checks (ConfigError after
    MAX_DRAWS draws)."""
    for _ in range(MAX_DRAWS):
        world = _draw(family, seed, config, rng)
        if world is not None:
            return world
    msg = f"no {family.value} world passed the checks in {MAX_DRAWS} draws (seed {seed})"
    raise ConfigError(msg)


def _draw(
    family: Family, seed: int, config: GenerateConfig, rng: np.random.Generator
) -> World | None:
    dead_end = family is Family.DEAD_END
    base = family
    if dead_end:
        base = Family.PASSAGES if rng.uniform() < 0.5 else Family.CLUTTER
    style = _Style.draw(rng)
    if base is Family.PASSAGES:
        drawn = _passages(config, rng, style, dead_end)
    else:
        drawn = _clutter(config, rng, style, dead_end)
    if drawn is None:
        return None
    obstacles, start, goal, difficulty = drawn
    if not _fits(obstacles, start, goal, config.max_extent):
        return None
    radius = config.robot_radius + config.margin
    check = _check(obstacles, start, goal, radius, config.check_cell)
    if check is None or check.reachable == dead_end:
        return None
    heading = round(float(rng.uniform(-60.0, 60.0)), 1)
    generated = GeneratedConfig(
        family=family.value,
        seed=seed,
        reachable=check.reachable,
        optimal_path_m=round(check.length, 3) if check.reachable else None,
        narrowest_gap_m=round(check.narrowest_gap, 3) if check.reachable else None,
        difficulty=difficulty,
        check_radius=radius,
    )
    spec = SceneSpec(
        name=f"{family.value}-{seed}",
        duration=config.duration,
        seed=seed,
        ground=GroundConfig(texture=style.ground),
        lighting=style.lighting,
        obstacles=tuple(obstacles),
        robot=RobotConfig(
            start=(start[0], start[1], heading), goal=goal, radius=config.robot_radius
        ),
        generated=generated,
        # the cameras of a real robot, as the bundled scenes' (docs/simulator.md)
        camera_defects=CameraDefects(ideal=False),
    )
    return World(spec, check)


def _check(
    obstacles: list[ObstacleConfig],
    start: tuple[float, float],
    goal: tuple[float, float],
    radius: float,
    cell: float,
) -> PathCheck | None:
    """The path check, or None when the start's free space is open (a point robot could
    leave the world's bounding box) or the start or goal is not free."""
    fp = compile_footprints(obstacles)
    xs = [p for ob in obstacles for p in _corners(ob)]
    lo = np.min(xs, axis=0) - 1.0
    hi = np.max(xs, axis=0) + 1.0
    grid = clearance_grid(fp, (lo[0], lo[1], hi[0], hi[1]), cell)
    for point in (start, goal):
        if grid.distance[grid.cell_of(*point)] < radius:
            return None
    outside = (float(lo[0]) + cell, float(lo[1]) + cell)
    if shortest_path(grid, start, outside, cell).reachable:
        return None
    return shortest_path(grid, start, goal, radius)


def _corners(ob: ObstacleConfig) -> list[tuple[float, float]]:
    if ob.kind is ObstacleKind.WALL:
        assert ob.start is not None and ob.end is not None
        return [ob.start, ob.end]
    assert ob.center is not None
    r = ob.radius if ob.radius is not None else math.hypot(*(ob.size or (0.0, 0.0))) / 2
    return [(ob.center[0] - r, ob.center[1] - r), (ob.center[0] + r, ob.center[1] + r)]


def _fits(
    obstacles: list[ObstacleConfig],
    start: tuple[float, float],
    goal: tuple[float, float],
    extent: float,
) -> bool:
    mid = np.array([(start[0] + goal[0]) / 2, (start[1] + goal[1]) / 2])
    pts = np.array([p for ob in obstacles for p in _corners(ob)])
    return bool(np.all(np.abs(pts - mid) <= extent / 2))


@dataclass(frozen=True)
class _Style:
    """The looks of one world: ground, light, wall heights and texture scale."""

    ground: TextureConfig
    lighting: LightingConfig
    height: tuple[float, float]
    feature: tuple[float, float]

    @classmethod
    def draw(cls, rng: np.random.Generator) -> _Style:
        ground = TextureConfig(
            color=_colour(rng, 0.3, 0.6),
            feature_size=round(float(rng.uniform(0.04, 0.06)), 3),
            contrast=round(float(rng.uniform(0.4, 0.6)), 2),
        )
        light = LightingConfig(
            azimuth_deg=round(float(rng.uniform(0.0, 360.0)), 1),
            elevation_deg=round(float(rng.uniform(35.0, 70.0)), 1),
            ambient=round(float(rng.uniform(0.3, 0.4)), 2),
        )
        low = float(rng.uniform(0.8, 1.2))
        return cls(ground, light, (low, low + 0.4), (0.03, 0.06))

    def texture(self, rng: np.random.Generator) -> TextureConfig:
        return TextureConfig(
            color=_colour(rng, 0.35, 0.85),
            feature_size=round(float(rng.uniform(*self.feature)), 3),
            contrast=round(float(rng.uniform(0.45, 0.7)), 2),
        )

    def wall_height(self, rng: np.random.Generator) -> float:
        return round(float(rng.uniform(*self.height)), 2)


def _colour(rng: np.random.Generator, lo: float, hi: float) -> tuple[float, float, float]:
    r, g, b = (round(float(c), 2) for c in rng.uniform(lo, hi, 3))
    return (r, g, b)


def _passages(
    config: GenerateConfig, rng: np.random.Generator, style: _Style, dead_end: bool
) -> tuple[list[ObstacleConfig], tuple[float, float], tuple[float, float], float] | None:
    count = 1 if dead_end else int(rng.integers(config.passages[0], config.passages[1] + 1))
    width = float(rng.uniform(*config.passage_width))
    rooms = [Room((0.0, 0.0), 0.0, *_room_half(config, rng, width))]
    lines = []
    for _ in range(count):
        line = _passage_line(config, rng, rooms[-1])
        lines.append(line)
        end, heading = line[-1], math.atan2(*(line[-1] - line[-2])[::-1])
        hl, hw = _room_half(config, rng, width)
        centre = end + (hl + Room.WALL) * np.array([math.cos(heading), math.sin(heading)])
        rooms.append(Room((float(centre[0]), float(centre[1])), heading, hl, hw))
    if not _separated(rooms, lines, width):
        return None
    obstacles: list[ObstacleConfig] = []
    for k, room in enumerate(rooms):
        doors = (k > 0, k < len(rooms) - 1)
        obstacles += room_walls(room, width, doors, style.texture(rng), style.wall_height(rng))
    block = int(rng.integers(1, len(lines[0]))) if dead_end else -1
    for line in lines:
        obstacles += passage_walls(
            line, width, style.texture(rng), style.wall_height(rng), block_leg=block, rng=rng
        )
    start = rooms[0].inside(rng, 0.4)
    goal = rooms[-1].inside(rng, 0.4)
    obstacles += _props(rng, style, rooms, [start, goal])
    return obstacles, start, goal, 0.0


def _room_half(
    config: GenerateConfig, rng: np.random.Generator, width: float
) -> tuple[float, float]:
    hl = float(rng.uniform(*config.room_half))
    hw = max(float(rng.uniform(*config.room_half)), width / 2 + 0.5)
    return round(hl, 2), round(hw, 2)


def _passage_line(config: GenerateConfig, rng: np.random.Generator, room: Room) -> np.ndarray:
    """The passage's centre line from the room's front door (outer face of its wall) on:
    ``legs`` straight legs, each turned from the last by a bend of either sign."""
    heading = room.heading
    point = np.array(room.front_door()) + Room.WALL * np.array(
        [math.cos(heading), math.sin(heading)]
    )
    points = [point]
    legs = int(rng.integers(config.legs[0], config.legs[1] + 1))
    for k in range(legs):
        if k:
            bend = math.radians(float(rng.uniform(*config.bend_deg)))
            heading += bend if rng.uniform() < 0.5 else -bend
        length = float(rng.uniform(*config.leg_length))
        point = point + length * np.array([math.cos(heading), math.sin(heading)])
        points.append(point)
    return np.array(points)


def _separated(rooms: list[Room], lines: list[np.ndarray], width: float) -> bool:
    """Whether no two pieces (rooms, passage legs) that do not meet by design come closer
    than a passage's width plus two walls."""
    pieces: list[tuple[np.ndarray, float]] = [(room.samples(), 0.0) for room in rooms]
    owners: list[tuple[int, ...]] = [(k,) for k in range(len(rooms))]
    for k, line in enumerate(lines):
        for a, b in itertools.pairwise(line):
            n = max(2, math.ceil(np.hypot(*(b - a)) / 0.1))
            pts = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
            pieces.append((pts, width / 2))
            owners.append((k, k + 1, 100 + len(pieces)))
    gap = 2 * Room.WALL + 0.3
    for i in range(len(pieces)):
        for j in range(i + 1, len(pieces)):
            adjacent = bool(set(owners[i]) & set(owners[j])) or (
                owners[i][-1] >= 100 and owners[j][-1] == owners[i][-1] + 1
            )
            if adjacent:
                continue
            (p, ri), (q, rj) = pieces[i], pieces[j]
            d = np.min(np.hypot(*(p[:, None, :] - q[None, :, :]).transpose(2, 0, 1)))
            if d < ri + rj + gap:
                return False
    return True


def _props(
    rng: np.random.Generator, style: _Style, rooms: list[Room], keep: list[tuple[float, float]]
) -> list[ObstacleConfig]:
    """0-2 boxes or cylinders in each room, at least 1 m from the start and goal."""
    out = []
    for room in rooms:
        for _ in range(int(rng.integers(0, 3))):
            centre = room.inside(rng, 0.5)
            if min(math.dist(centre, p) for p in keep) < 1.2:
                continue
            out.append(_prop(rng, style, centre))
    return out


def _prop(rng: np.random.Generator, style: _Style, centre: tuple[float, float]) -> ObstacleConfig:
    texture = style.texture(rng)
    height = round(float(rng.uniform(0.5, 1.3)), 2)
    if rng.uniform() < 0.5:
        r = round(float(rng.uniform(0.1, 0.3)), 2)
        return ObstacleConfig(
            kind=ObstacleKind.CYLINDER, center=centre, radius=r, height=height, texture=texture
        )
    size = (round(float(rng.uniform(0.2, 0.6)), 2), round(float(rng.uniform(0.2, 0.6)), 2))
    yaw = round(float(rng.uniform(0.0, 180.0)), 1)
    return ObstacleConfig(
        kind=ObstacleKind.BOX, center=centre, size=size, yaw_deg=yaw, height=height, texture=texture
    )


def density(difficulty: float) -> float:
    """Clutter obstacles per square metre of the field at ``difficulty`` (0-1)."""
    return 0.1 + 0.3 * difficulty


def _clutter(
    config: GenerateConfig, rng: np.random.Generator, style: _Style, dead_end: bool
) -> tuple[list[ObstacleConfig], tuple[float, float], tuple[float, float], float] | None:
    length = round(float(rng.uniform(*config.arena_length)), 2)
    width = round(float(rng.uniform(*config.arena_width)), 2)
    start = (0.0, round(float(rng.uniform(-0.25, 0.25)) * width, 2))
    goal = (length, round(float(rng.uniform(-0.25, 0.25)) * width, 2))
    arena = Room((length / 2, 0.0), 0.0, length / 2 + 1.0, width / 2)
    obstacles = room_walls(arena, 0.0, (False, False), style.texture(rng), style.wall_height(rng))
    field = (1.0, -width / 2, length - 1.0, width / 2)
    obstacles += clutter_field(
        rng, field, density(config.difficulty), [start, goal], style.texture, style.wall_height
    )
    if dead_end:
        x = round(float(rng.uniform(0.35, 0.65)) * length, 2)
        obstacles.append(
            ObstacleConfig(
                kind=ObstacleKind.WALL,
                start=(x, -width / 2),
                end=(x, width / 2),
                height=style.wall_height(rng),
                texture=style.texture(rng),
            )
        )
    return obstacles, start, goal, config.difficulty


def world_text(world: World) -> str:
    """The world as a scene file, headed by what was checked."""
    from flylog.scene.scene_text import scene_text

    g = world.spec.generated
    assert g is not None
    found = (
        f"shortest path {world.check.length:.2f} m, narrowest gap {world.check.narrowest_gap:.2f} m"
        if world.check.reachable
        else "no path"
    )
    header = (
        f"A generated '{g.family}' world (flylog scene generate {g.family} --seed {g.seed}).\n"
        f"Checked on a {GenerateConfig().check_cell:g} m grid for a footprint of radius "
        f"{g.check_radius:g} m: {found}."
    )
    return scene_text(world.spec, header)


def generate_text(family: Family, seed: int, config: GenerateConfig) -> str:
    """The scene file of ``family``'s world for ``seed`` (its own generator, seeded with
    ``seed``), parsed back as a check of the text."""
    from flylog.scene.load import parse_scene

    world = generate_world(family, seed, config, np.random.default_rng(seed))
    text = world_text(world)
    parse_scene(text, source=f"{family.value} seed {seed}")
    return text


def check_world_folder(folder: Path, count: int) -> None:
    """OutputError if ``folder`` exists and is not a folder (checked before ``count``
    worlds are generated for it, not after)."""
    from flylog.errors import OutputError

    if folder.exists() and not folder.is_dir():
        msg = f"{folder} is not a folder, and {count} worlds need one"
        raise OutputError(msg, path=folder)


def write_worlds(texts: dict[Path, str], folder: Path) -> None:
    """Write the scene files ``texts`` (path → text) into ``folder``, published together
    (:class:`flylog.io.atomic.Batch`): a failure or a stop leaves every file that was there
    as it was, and a folder made here is removed again. OutputError if ``folder`` exists
    and is not a folder."""
    import os

    from flylog.io.atomic import Batch, publish, temporary_beside

    folder = Path(folder)
    check_world_folder(folder, len(texts))
    made = not folder.exists()
    if made:
        folder.mkdir(parents=True)
    try:
        with Batch() as batch:
            for path, text in texts.items():
                fd, tmp = temporary_beside(path)
                try:
                    with os.fdopen(fd, "wb") as fh:
                        fh.write(text.encode("utf-8"))
                    publish(tmp, path, batch)
                except BaseException:
                    tmp.unlink(missing_ok=True)
                    raise
    except BaseException:
        if made and not any(folder.iterdir()):
            folder.rmdir()
        raise
