"""Configuration of the harmonic-function planner (the ``[planner]`` table)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from flylog.config import param
from flylog.errors import ConfigError


class Relaxation(enum.Enum):
    """Which implementation of the red–black SOR sweep the planner runs."""

    NUMBA = "numba"
    NUMPY = "numpy"


@dataclass(frozen=True)
class PlannerConfig:
    """The grid, its relaxation, obstacle detection from flies, and the unicycle steering."""

    extent: float = param(
        20.0,
        help="side of the square grid over the odometric frame (centred between start and "
        "goal). Its border is an obstacle: a grid much larger than the mission lets the "
        "harmonic field prefer wide detours round the scene to gaps between obstacles, and "
        "a grid as small as 14 m on corridor and clutter saturates U near 1, where the "
        "gradient is too flat to steer by",
        unit="m",
        min=0.5,
    )
    cell_size: float = param(0.1, help="side of one grid cell", unit="m", min=0.005)
    sweeps_per_tick: int = param(
        40, help="red–black SOR sweeps run at each planner tick", min=1, max=100_000
    )
    max_sweeps_per_tick: int = param(
        40,
        help="a tick keeps sweeping (in chunks of sweeps_per_tick) while the last sweep "
        "changed a cell by more than relax_tolerance, up to this many sweeps in all "
        "(at most sweeps_per_tick: a fixed number of sweeps per tick)",
        min=1,
        max=1_000_000,
    )
    warm_start_sweeps: int = param(
        5000,
        help="before the first tick, the obstacle-free field is relaxed at the grid's optimal "
        "over-relaxation until a sweep changes U by at most relax_tolerance, or this many "
        "sweeps (700 on 200×200, 0.03 s). "
        "From its log-distance guess alone, the field far from the goal needs hundreds of "
        "ticks to settle, and meanwhile its direction at the robot swings round: a full turn "
        "in place at the start of a corridor run (0 = no warm start)",
        min=0,
        max=10_000_000,
    )
    relax_tolerance: float = param(
        1e-10,
        help="largest change of a sweep below which a tick stops sweeping early",
        min=0.0,
    )
    omega: float = param(
        1.9, help="SOR over-relaxation factor (1 = Gauss–Seidel; must stay below 2)", min=0.5
    )
    relaxation: Relaxation = param(
        Relaxation.NUMBA, help="implementation of the sweep: 'numba' or the 'numpy' reference"
    )
    tick_rate: float = param(
        10.0,
        help="planner ticks per second (at most 10 x the camera's frame rate)",
        unit="Hz",
        min=0.01,
        max=10_000.0,
    )
    density_radius: float = param(
        0.1,
        help="half-width of the square window over which the fly density is measured",
        unit="m",
        min=0.0,
    )
    density_threshold: float = param(
        30.0,
        help="obstacle flies per square metre (over the density window) that make an obstacle",
        unit="1/m^2",
        min=0.0,
    )
    robot_radius: float = param(
        0.3, help="radius of the robot's footprint: obstacles are inflated by it", unit="m", min=0.0
    )
    inflation_margin: float = param(
        0.05,
        help="added to robot_radius when inflating obstacles (the stated clearance): room for "
        "odometric drift and the robot's swing. Cells are inflated by whole cells along the "
        "axes, so a passage whose walls are mapped at their faces keeps a free channel when "
        "it is at least (2·floor((robot_radius + this) / cell_size) + 3) cells wide: 0.9 m "
        "with the defaults, which leave 4 free cells across a 1.2 m passage (0.1 would "
        "leave 2, and a wall cell mapped one cell off closes it)",
        unit="m",
        min=0.0,
    )
    escape_rise: float = param(
        0.1,
        help="extra Dirichlet value at detected cells, falling to 1 at the obstacle's skin, so "
        "a robot inside an inflated obstacle is steered out (0 = a flat 1, as in the paper)",
        min=0.0,
        max=1.0,
    )
    obstacle_weight: float = param(
        0.1,
        help="weight of an obstacle cell among a free cell's four neighbours in the "
        "relaxation: 1 = Dirichlet obstacles (U = 1 on them, the paper's form); below 1 a "
        "Robin boundary (towards reflecting as it falls) under which U does not decay "
        "exponentially along a corridor, so a narrow passage to the goal is not outweighed "
        "by a wide detour (U stays harmonic: no local minima; border 1 and goal 0 remain). "
        "With the true obstacles of the corridor and clutter scenes, relaxed to convergence, "
        "the descent from the start at 1 leaves the corridor backwards and goes round the "
        "clutter outside its walls (25 m and more); at 0.1 it runs through both (10.9 m and "
        "10.5 m, clearance 0.82 m and 0.47 m)",
        min=0.0,
        max=1.0,
    )
    frontier_field: bool = param(
        False,
        help="while the goal is not among the cells seen free that the robot can reach, the "
        "unseen cells beside them nearest the goal (the frontier on the goal's side) are the "
        "field's sinks in the goal's place: the robot goes to look there, not round the "
        "outside of walls it has not mapped yet (off: the goal is the sink, and unseen "
        "cells count as free space either way)",
    )
    frontier_band: float = param(
        0.5,
        help="with frontier_field, the frontier cells that pull: those within this of the "
        "straight-line distance to the goal of the frontier's nearest cell",
        unit="m",
        min=0.0,
    )
    clear_free_cells: bool = param(
        True,
        help="forget obstacle cells that the cameras see as free (in view, not occluded)",
    )
    confirm_after_views: int = param(
        2,
        help="consecutive updates a cell must be seen dense before it becomes an obstacle: "
        "counted in planner ticks (time), not engine generations, so a population that has "
        "not converged yet cannot plant phantom obstacles whatever the compute budget",
        min=1,
        max=10_000,
    )
    clear_after_views: int = param(
        3,
        help="consecutive updates a remembered obstacle cell must be seen free to be cleared",
        min=1,
        max=10_000,
    )
    clear_min_range: float = param(
        0.0,
        help="remembered obstacle cells nearer than this to the robot are never cleared as "
        "seen free: close up, an obstacle fills the view, lies nearer than the depths the "
        "engine searches (engine.d_min + the camera's mount) and loses its flies, which is "
        "no evidence that it has gone (0 = off; at 1.0 on clutter no box is cleared into a "
        "collision, but phantom cells near the goal are kept too and stall the robot)",
        unit="m",
        min=0.0,
    )
    sonar_range: float = param(
        1.0,
        help="a sonar echo nearer than this marks the cells along its arc (the range, across "
        "the cone) as obstacles at once, without confirmation: near the robot and beside the "
        "cameras' view the flies see nothing (nearer than engine.d_min, or not in the "
        "images), and a robot turning towards the goal sweeps into obstacles it has never "
        "seen (0 = obstacles from the flies only, as in the paper)",
        unit="m",
        min=0.0,
    )
    sonar_clears: bool = param(
        True,
        help="a sonar's cone up to its echo (up to its maximum range without one), less "
        "sonar_free_margin, counts as seen free, and the flies in it are left out of the "
        "density: false matches that gather at a near, confident depth in an empty passage "
        "outweigh the lines of sight through them, but the sonars hear nothing there "
        "(docs/navigation.md; sonar-absorbing obstacles are cleared too)",
    )
    sonar_free_margin: float = param(
        0.15,
        help="how much nearer than a sonar's echo (or its maximum range) a cell's centre must "
        "lie to count as sonar-free: the range noise (0.02 m) three times over and a cell's "
        "half-diagonal (0.07 m)",
        unit="m",
        min=0.0,
    )
    view_range: float = param(
        6.0, help="default camera view range for obstacle updates", unit="m", min=0.0
    )
    max_depth_per_pixel: float = param(
        0.75,
        help="obstacle flies are mapped, and cells seen free, only as far as one pixel of "
        "disparity spans at most this much depth (Z²/(focal·baseline)): 4.7 m at 320×240 "
        "with the default rig; at 640×480 (6.7 m) view_range bounds it. Farther away a "
        "fly's depth is too coarse to place a cell: boxes turn into blobs stretched along "
        "the view that close the corridor (0 = map up to view_range)",
        unit="m",
        min=0.0,
    )
    full_weight_depth_error: float = param(
        0.15,
        help="an obstacle fly counts as one fly in the density while its depth error (one "
        "pixel of disparity, Z²/(focal·baseline)) is at most this, and as (this / error) of "
        "one beyond: at 320×240 with the default rig a fly at 2.1 m counts 1, at 4 m 0.28, "
        "so coarse far flies smeared along the view need several times their number to "
        "make a cell dense (0 = every fly counts 1, as in the paper)",
        unit="m",
        min=0.0,
    )
    see_through: bool = param(
        True,
        help="cells on the line of sight from the robot to an obstacle fly, nearer than the "
        "fly's depth less its depth error and one cell, are looked through: a cell more fly "
        "weight looks through than lies in is free this update (needs "
        "full_weight_depth_error above 0)",
    )
    max_linear_speed: float = param(0.5, help="maximum forward speed", unit="m/s", min=0.0)
    max_angular_speed: float = param(
        0.5,
        help="maximum turn rate. The simulated odometry's heading noise grows with the turn "
        "rate, so the heading variance of a turn grows with rate × angle: on corridor the "
        "robot turns ~10.7 rad a run (most of it at the start, while the walls come into "
        "view): ∫ω²dt is 6.9 rad²/s at 1 rad/s and 4.2 at 0.5",
        unit="rad/s",
        min=0.0,
    )
    heading_gain: float = param(
        2.0, help="turn rate per radian of heading error", unit="1/s", min=0.0
    )
    turn_in_place_deg: float = param(
        25.0,
        help="heading error beyond which the robot turns in place (no forward speed); below "
        "it the forward speed falls from the maximum (facing the direction) to 0 at this error. "
        "Below the cameras' half field of view (32.6° for the bundled rig), so the robot "
        "drives only towards what it has in view (at 60° it sweeps into obstacles beside "
        "the view while turning towards the goal)",
        unit="deg",
        min=1.0,
        max=180.0,
    )
    obstacle_slowdown: float = param(
        0.5,
        help="the forward speed is scaled by (clearance / this) when the nearest obstacle cell "
        "is closer than robot_radius + this (0 = never slow down near obstacles)",
        unit="m",
        min=0.0,
    )
    min_speed_fraction: float = param(
        0.2,
        help="the obstacle slow-down never takes the forward speed below this fraction of "
        "max_linear_speed (the robot must still be able to leave)",
        min=0.0,
        max=1.0,
    )
    heading_smoothing: float = param(
        0.5,
        help="time constant of a low-pass filter on the steering direction: where the field "
        "is nearly flat, −∇U swings with every obstacle cell appearing or clearing nearby, "
        "and every radian turned adds odometric heading drift (0 = no filter)",
        unit="s",
        min=0.0,
    )
    lookahead: float = param(
        0.5,
        help="steer at the point this far down the descent path (followed from the robot in "
        "path_step steps) instead of along −∇U at the robot: turns smoothly through the "
        "field's bends and a moment's ripples of the field, and every radian turned adds "
        "odometric heading drift (0 = along the local gradient)",
        unit="m",
        min=0.0,
    )
    goal_tolerance: float = param(
        0.05,
        help="the planner stops (GOAL_REACHED) when its ODOMETRIC position is this close to the "
        "goal; the metrics judge the true position with their own, separate tolerance",
        unit="m",
        min=0.0,
    )
    goal_approach_distance: float = param(
        0.3,
        help="within this distance the robot steers straight at the goal point instead of "
        "along −∇U, whose sink is the goal cell's centre (up to half a cell diagonal away)",
        unit="m",
        min=0.0,
    )
    goal_slowdown: float = param(
        0.5,
        help="within this distance of the goal the forward speed is scaled by (distance / "
        "this), so the robot stops inside goal_tolerance instead of overshooting it",
        unit="m",
        min=0.0,
    )
    stuck_time: float = param(
        60.0,
        help="time without progress towards the goal after which the status is STUCK (and "
        "a closed loop ends stuck_timeout later): longer than the scenes' detours, in which "
        "the distance to the goal grows. On clutter, a robot that goes round the outside of "
        "the walls is 12.8 m from the goal at the walls' far corner, 2.8 m farther than at "
        "the start; at 20 s the closed loop ends 2 of 3 such runs there",
        unit="s",
        min=0.0,
    )
    stuck_progress: float = param(
        0.1,
        help="decrease of the best distance to the goal that counts as progress",
        unit="m",
        min=0.0,
    )
    stuck_timeout: float = param(
        10.0,
        help="a closed-loop simulation ends once the planner has reported STUCK for this "
        "long without a break (its status goes into the summary and the log's metadata)",
        unit="s",
        min=0.0,
    )
    cut_off_time: float = param(
        1.0,
        help="how long the map must cut the robot off from the goal (no free cells connect "
        "them) before the first recovery: a phantom cell that closes a passage for a tick "
        "or two is cleared by the next views",
        unit="s",
        min=0.0,
    )
    look_around_deg: float = param(
        360.0,
        help="first recovery: the robot turns on the spot through this angle, so the cameras "
        "see round it and clear what they see free",
        unit="deg",
        min=0.0,
        max=3600.0,
    )
    stale_keep_distance: float = param(
        0.5,
        help="second recovery: remembered obstacle cells seen since the look-around began "
        "(in view, not in a shadow) and farther than this from every cell of those updates' "
        "evidence (dense in view, or a sonar echo) are forgotten",
        unit="m",
        min=0.0,
    )
    backup_distance: float = param(
        0.3,
        help="third recovery: the robot backs up this far (not if a remembered obstacle lies "
        "within robot_radius + inflation_margin of where it would end)",
        unit="m",
        min=0.0,
    )
    backup_speed: float = param(0.15, help="speed of the back-up", unit="m/s", min=0.0)
    path_max_steps: int = param(
        500, help="bound on the gradient-descent steps of the planned path", min=1, max=1_000_000
    )
    path_step: float = param(
        0.05, help="length of one gradient-descent step of the planned path", unit="m", min=1e-4
    )

    def __post_init__(self) -> None:
        if not self.omega < 2.0:
            msg = f"omega must be below 2 for SOR to converge, got {self.omega}"
            raise ConfigError(msg)
        if not self.obstacle_weight > 0.0:
            msg = (
                "obstacle_weight must be above 0 (a free cell walled in on four sides would "
                f"have no neighbour to average), got {self.obstacle_weight}"
            )
            raise ConfigError(msg)
        if self.cells < 5:
            msg = (
                f"extent {self.extent} m at cell size {self.cell_size} m gives {self.cells} "
                "cells a side; need at least 5"
            )
            raise ConfigError(msg)

    @property
    def cells(self) -> int:
        """Cells along each side of the square grid."""
        return max(1, round(self.extent / self.cell_size))

    @property
    def warm_start_omega(self) -> float:
        """The warm start's over-relaxation factor: the optimum for Laplace's equation on a
        square grid with a fixed border, 2 / (1 + sin(π / (cells − 1))): 1.969 on 200×200,
        where the obstacle-free field settles in 700 sweeps instead of omega's 3100. A tick
        keeps ``omega``: it relaxes the local change of an obstacle update in 40 sweeps."""
        return 2.0 / (1.0 + math.sin(math.pi / (self.cells - 1)))

    @property
    def tick_period(self) -> float:
        """Seconds between planner ticks."""
        return 1.0 / self.tick_rate

    def mapping_range(self, focal_px: float, baseline: float) -> float:
        """How far (m) obstacle flies are mapped from a stereo rig of ``focal_px`` pixels
        and ``baseline`` metres: ``view_range``, cut where one pixel of disparity spans
        ``max_depth_per_pixel`` of depth."""
        if self.max_depth_per_pixel <= 0.0:
            return self.view_range
        return min(self.view_range, math.sqrt(self.max_depth_per_pixel * focal_px * baseline))

    @property
    def inflation_cells(self) -> float:
        """The inflation radius (robot radius plus margin) in cells."""
        return (self.robot_radius + self.inflation_margin) / self.cell_size

    @property
    def density_window_cells(self) -> int:
        """Half-width of the density window in cells (0 = the cell alone)."""
        return math.floor(self.density_radius / self.cell_size + 0.5)
