import math
from pathlib import Path

import numpy as np
import pytest

from flylog.errors import ConfigError
from flylog.scene import ObstacleKind, distance_to_obstacles, load_scene, parse_scene
from flylog.scene.footprints import ray_hits_numpy
from flylog.scene.ray_kernel import ray_hit

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
SCENES = ["corridor", "turn", "near-obstacle", "clutter"]


@pytest.mark.parametrize("name", SCENES)
def test_fixture_scenes_load_at_640x480_15hz(name):
    scene = load_scene(FIXTURES / f"{name}.toml")
    assert scene.name == name
    assert (scene.spec.camera.width, scene.spec.camera.height) == (640, 480)
    assert scene.spec.camera.frame_rate == 15.0
    assert scene.text == (FIXTURES / f"{name}.toml").read_text()
    # Start and goal are free for the robot.
    free = distance_to_obstacles(scene, np.array([scene.start_pose.as_array()[:2], scene.goal]))
    assert np.all(free > scene.spec.robot.radius)


def test_clutter_is_deterministic_and_keeps_start_and_goal_clear():
    text = (FIXTURES / "clutter.toml").read_text()
    a, b = parse_scene(text, "a"), parse_scene(text, "b")
    assert a.obstacles == b.obstacles
    assert len(a.obstacles) == 2 + a.spec.clutter.count
    other = parse_scene(text.replace("seed = 7", "seed = 8"), "c")
    assert other.obstacles != a.obstacles
    placed = a.footprints
    centres = np.stack([placed.cx, placed.cy], axis=1)[2:]
    clear = a.spec.clutter.clear_radius
    for point in (a.start_pose.as_array()[:2], np.array(a.goal)):
        gap = np.hypot(*(centres - point).T) - placed.bounding_radius()[2:]
        assert gap.min() >= clear


def test_clutter_that_cannot_fit_names_the_field():
    text = 'name = "x"\n[clutter]\ncount = 40\narea = [0.0, 0.0, 2.0, 2.0]\n'
    with pytest.raises(ConfigError, match=r"s\.toml: field 'clutter\.count': could place only"):
        parse_scene(text, "s.toml")


BOX = '[[obstacles]]\nkind = "box"\ncenter = [1.0, 1.0]\nsize = [1.0, 1.0]\n'


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            BOX * 2 + '[[obstacles]]\nkind = "box"\ncenter = [1.0, 1.0]\nsize = [1.0, 1.0]\n'
            "height = -1.0\n",
            r"f\.toml: field 'obstacles\[2\]\.height': must be at least 0\.001 m, got -1\.0",
        ),
        (
            '[[obstacles]]\nkind = "wall"\ncenter = [1.0, 1.0]\n',
            r"f\.toml: obstacles\[0\]: a wall takes start and end, not 'center'",
        ),
        (
            '[[obstacles]]\nkind = "cylinder"\ncenter = [1.0, 1.0]\n',
            r"obstacles\[0\]: a cylinder needs 'radius'",
        ),
        ('[[obstacles]]\nkind = "cone"\n', r"'obstacles\[0\]\.kind': expected one of 'box'"),
        ("[[obstacles]]\ncenter = [1.0, 1.0]\n", r"missing field 'obstacles\[0\]\.kind'"),
        ("[robot]\nstart = [0.0, 0.0]\n", r"'robot\.start': expected a list of 3 values"),
        ("[camera]\nwidht = 320\n", r"unknown field 'camera\.widht'"),
        (
            "[drive]\nwaypoints = [[1.0, 2.0]]\ncommands = [{ t_start = 0.0 }]\n",
            r"drive: give either 'waypoints' or 'commands', not both",
        ),
        ("[drive]\ncommands = [{ v = 1.0 }]\n", r"missing field 'drive\.commands\[0\]\.t_start'"),
        ("[[obstacles]\n", r"f\.toml: not valid TOML"),
    ],
)
def test_bad_scene_files_name_file_and_field(body, message):
    with pytest.raises(ConfigError, match=message):
        parse_scene('name = "x"\n' + body, "f.toml")


def test_load_scene_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        load_scene(tmp_path / "nope.toml")


def test_minimal_scene_defaults():
    scene = parse_scene('name = "empty"\n', "mem")
    assert scene.obstacles == ()
    assert scene.spec.camera.width == 640
    assert math.isinf(distance_to_obstacles(scene, np.zeros((1, 2)))[0])


def test_distance_to_obstacles_known_geometry():
    text = """
name = "d"
[[obstacles]]
kind = "box"
center = [0.0, 0.0]
size = [2.0, 1.0]
yaw_deg = 90.0
[[obstacles]]
kind = "cylinder"
center = [10.0, 0.0]
radius = 1.0
[[obstacles]]
kind = "wall"
start = [0.0, 20.0]
end = [10.0, 20.0]
thickness = 0.2
[robot]  # clear of the obstacles: a scene with one over the start or the goal is refused
start = [5.0, 10.0, 0.0]
goal = [5.0, -10.0]
"""
    scene = parse_scene(text, "mem")
    assert [o.kind for o in scene.obstacles] == list(ObstacleKind)
    pts = np.array(
        [
            [0.0, 0.0],  # inside the box
            [0.5 + 1.0, 0.0],  # the rotated box is 1 m wide in x: 1 m from its side
            [0.0, 1.0 + 2.0],  # and 2 m long in y: 2 m from its end
            [1.5, 2.0],  # 1 m, 1 m from its corner
            [13.0, 0.0],  # 2 m from the cylinder
            [5.0, 18.0],  # 1.9 m from the wall's face
            [-1.0, 20.0],  # 0.9 m from the wall's end cap (half the thickness)
        ]
    )
    expect = [0.0, 1.0, 2.0, math.sqrt(2.0), 2.0, 1.9, 0.9]
    assert distance_to_obstacles(scene, pts) == pytest.approx(expect)


def test_ray_hit_numba_matches_numpy():
    scene = load_scene(FIXTURES / "clutter.toml")
    fp = scene.footprints
    rng = np.random.default_rng(3)
    for _ in range(50):
        ox, oy = rng.uniform(-2, 12), rng.uniform(-4, 4)
        a = rng.uniform(-math.pi, math.pi)
        dx, dy = math.cos(a), math.sin(a) * 1.3
        ref = np.array(ray_hits_numpy(fp, ox, oy, dx, dy))
        got = np.array(
            [
                ray_hit(
                    fp.kind[k],
                    fp.cx[k],
                    fp.cy[k],
                    fp.cos[k],
                    fp.sin[k],
                    fp.hx[k],
                    fp.hy[k],
                    ox,
                    oy,
                    dx,
                    dy,
                )
                for k in range(len(fp))
            ]
        ).T
        hit = np.isfinite(ref[0])
        assert np.array_equal(hit, np.isfinite(got[0]))
        assert got[:, hit] == pytest.approx(ref[:, hit], abs=1e-12)


def test_ray_hit_known_box():
    # Unit box at x = 3, ray along +x from the origin: enters at 2.5 through the -x face.
    t_in, t_out, nx, ny = ray_hit(0, 3.0, 0.0, 1.0, 0.0, 0.5, 0.5, 0.0, 0.0, 1.0, 0.0)
    assert (t_in, t_out, nx, ny) == pytest.approx((2.5, 3.5, -1.0, 0.0))
