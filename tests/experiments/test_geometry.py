"""Known geometry: which obstacle the robot touched, which grid cells lie on a footprint."""

import numpy as np
import pytest

from flylog.experiments.closed_loop import describe_obstacle, touched_obstacles
from flylog.experiments.reaction import entered_view_pixels, footprint_cells
from flylog.experiments.sonar import flies_on_obstacle, nearest_obstacle
from flylog.geometry import StereoRig
from flylog.scene.load import parse_scene

SCENE = parse_scene(
    """
name = "two"
[[obstacles]]
kind = "box"
center = [3.0, 0.0]
size = [1.0, 1.0]
height = 0.5
low_texture = true
[[obstacles]]
kind = "cylinder"
center = [1.0, 2.0]
radius = 0.2
height = 0.9
""",
    "test",
)


def test_touched_obstacles_are_those_the_robot_disc_entered():
    radius = 0.3
    # along y = 0.75: 0.25 m from the box's side (y = 0.5), inside the robot's radius
    xy = np.column_stack([np.linspace(0.0, 5.0, 51), np.full(51, 0.75)])
    assert touched_obstacles(SCENE, xy, radius) == [0]
    # along y = -0.85: 0.35 m from the box: clear
    assert touched_obstacles(SCENE, xy - [0.0, 1.6], radius) == []
    assert describe_obstacle(SCENE, 0) == "#0 (box, untextured, at x = 3.0, y = 0.0)"


def test_footprint_cells_within_one_cell_of_the_box():
    xy = np.array([[3.0, 0.0], [3.55, 0.0], [3.75, 0.0], [1.0, 2.0]])
    assert footprint_cells(SCENE, 0, xy, 0.1).tolist() == [True, True, False, False]
    assert footprint_cells(SCENE, 1, xy, 0.1).tolist() == [False, False, False, True]


def test_nearest_obstacle_and_flies_on_it():
    assert nearest_obstacle(SCENE) == 1  # the cylinder, 2.0 - 0.2 m away from the origin
    world = np.array([[1.0, 1.75], [1.0, 1.85], [1.0, 1.5], [1.0, 2.0]])
    z = np.array([[0, 0, 0.5], [0, 0, 1.5], [0, 0, 0.5], [0, 0, 0.95]])
    # 0.05 m from the disc and low enough; too high; 0.3 m away; inside, within the margin
    assert flies_on_obstacle(SCENE, 1, world, z) == 2


def test_entered_view_share_scales_with_the_image():
    rig = StereoRig(width=640, height=480, focal_px=500.0)
    assert entered_view_pixels(rig) == 400
    small = StereoRig(width=320, height=240, focal_px=250.0)
    assert entered_view_pixels(small) == 100


def test_scene_extent_holds_obstacles_start_goal_and_paths():
    from flylog.experiments.plots import Path2D, scene_extent

    xmin, xmax, ymin, ymax = scene_extent(SCENE, margin=0.5)
    # box 2.5..3.5 (bounding circle radius 0.707 around (3, 0)), cylinder at (1, 2) r 0.2,
    # start (0, 0), goal (10, 0) by default
    assert xmin == -0.5 and xmax == 10.5
    assert ymin == pytest.approx(-0.5 - 2**0.5 / 2) and ymax == pytest.approx(2.7)
    path = Path2D(np.array([[0.0, 0.0], [4.0, -3.0]]))
    assert scene_extent(SCENE, [path], margin=0.0)[2] == -3.0
