"""The ``[camera_defects]`` table of a scene file: what a real camera does to the light.

The renderer draws ideal images: both cameras share one exposure, with no noise, no blur and
no fall-off. A real machine-vision camera on a robot differs from that in every respect the
fields below name; :mod:`flylog.sim.camera` applies them to the renderer's images.

``ideal = true`` (the default, so a scene without the table is unchanged) bypasses the model:
the images are the renderer's, bit for bit. With ``ideal = false`` every field takes effect;
its default is the typical value of a global-shutter CMOS machine-vision camera (3.45 µm
pixels, 8-bit output) on an indoor robot, and setting a field to its neutral value (given in
its help) turns that one defect off. The rolling shutter (``row_period_us``) is off by
default: a global shutter.

The noise model is EMVA 1288's linear model: a pixel collects a Poisson number of electrons
(shot noise, variance equal to the mean), adds a Gaussian dark noise (read noise, electrons
rms), and the ADC converts with a system gain K in DN per electron and quantises (variance
1/12 DN²). The sensor figures are typical of Sony's Pregius 3.45 µm global-shutter pixels
(IMX273, IMX296 class): about 10 000 e⁻ of saturation capacity and 2–3 e⁻ rms of read noise.
They are typical values, not a quotation of one datasheet.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from flylog.config import param
from flylog.errors import ConfigError
from flylog.io.shutter import readout_excess


class CameraPreset(enum.Enum):
    """The named camera models `flylog simulate --camera` chooses between."""

    IDEAL = "ideal"  # the renderer's images as they are
    REALISTIC = "realistic"  # every field at its typical default


@dataclass(frozen=True)
class CameraDefects:
    """What a real camera does to the light before its 8-bit image (applied by
    :mod:`flylog.sim.camera`)."""

    ideal: bool = param(
        True,
        help="true: the renderer's images bit for bit, every field below ignored; false: "
        "the camera model",
    )
    exposure_ms: float = param(
        8.0,
        help="exposure time of every row of both cameras (triggered together); it sets "
        "the signal and the motion blur's length; at most the frame period",
        unit="ms",
        min=0.001,
        max=10000.0,
    )
    row_period_us: float = param(
        0.0,
        help="rolling shutter: the time from one row's exposure to the next's; row v's "
        "exposure middle is the frame's stamp + v x row_period_us (0: a global shutter, "
        "every row at the stamp). A rolling-shutter CMOS reads a row in about 19 us: "
        "18.9 us on Sony's IMX219 (Linux driver imx219.c: 3448 pixel clocks a line at "
        "182.4 Mpx/s). The readout, image height x row_period_us, must fit in the frame "
        "period",
        unit="us",
        min=0.0,
        max=100000.0,
    )
    white_flux: float = param(
        190.0,
        help="electrons a white surface (rendered value 1) collects per millisecond of "
        "exposure at the image centre: the scene's illumination (190 e-/ms x 8 ms fills "
        "15 % of the well, an indoor scene)",
        unit="e-/ms",
        min=0.0,
    )
    full_well: float = param(
        10000.0,
        help="saturation capacity of a pixel (typical of 3.45 um global-shutter CMOS)",
        unit="e-",
        min=1.0,
    )
    gain_db: float = param(
        12.0,
        help="left camera's analogue gain; 0 dB maps a full well to 255 DN (a robot's "
        "short exposure indoors is brightened with gain)",
        unit="dB",
        min=-20.0,
        max=48.0,
    )
    right_gain_ratio: float = param(
        1.1,
        help="right camera's gain over the left's (two auto-exposures settle apart; 1: matched)",
        min=0.1,
        max=10.0,
    )
    drift_sd: float = param(
        0.05,
        help="auto-exposure drift: stationary sd of the log exposure of each camera, an "
        "Ornstein-Uhlenbeck process, independent per camera (0: none)",
        min=0.0,
        max=1.0,
    )
    drift_tau_s: float = param(
        5.0, help="auto-exposure drift's time constant", unit="s", min=0.001, max=1e6
    )
    gamma: float = param(
        0.8,
        help="response curve: output = input ** gamma on [0, 1] after the gain (1: linear; "
        "0.45 is close to sRGB's encoding)",
        min=0.1,
        max=10.0,
    )
    shot_noise: bool = param(True, help="Poisson noise of the collected electrons (false: none)")
    read_noise_e: float = param(
        2.5,
        help="dark (read) noise, Gaussian, per pixel and frame (typical of 3.45 um "
        "global-shutter CMOS; 0: none)",
        unit="e- rms",
        min=0.0,
        max=1000.0,
    )
    dsnu_e: float = param(
        1.0,
        help="fixed-pattern dark offset per pixel (DSNU), fixed per camera for a seed (0: none)",
        unit="e- rms",
        min=0.0,
        max=1000.0,
    )
    prnu: float = param(
        0.01,
        help="fixed-pattern gain per pixel (PRNU), fixed per camera for a seed, as a "
        "fraction of the signal (0: none)",
        min=0.0,
        max=0.5,
    )
    vignetting_corner: float = param(
        0.8,
        help="relative illumination at the image corners, a cos^4-law profile "
        "1/(1 + a r^2)^2 scaled to it (1: none)",
        min=0.05,
        max=1.0,
    )
    psf_sigma_px: float = param(
        0.6,
        help="optical blur: the Gaussian point spread's sigma in pixels of the output "
        "image (0: none)",
        unit="px",
        min=0.0,
        max=10.0,
    )
    motion_samples: int = param(
        4,
        help="motion blur: renders averaged over the exposure, at poses spread evenly "
        "over it along the robot's commanded motion (1: none); at 0.5 m/s and 45 deg/s on "
        "corridor (320x240, 8 ms) the mean of 4 is within 0.7 DN rms of the mean of 32, "
        "a single render 3.0 DN",
        min=1,
        max=64,
    )

    @classmethod
    def preset(cls, name: CameraPreset) -> CameraDefects:
        """The named model: ideal (the table's defaults) or realistic (ideal = false)."""
        return cls(ideal=name is CameraPreset.IDEAL)


def check_exposure(defects: CameraDefects, frame_rate: float, *, source: str) -> None:
    """A camera cannot expose for longer than its frame period: ConfigError naming
    ``camera_defects.exposure_ms`` in ``source`` and the bound."""
    period_ms = 1000.0 / frame_rate
    if not defects.ideal and defects.exposure_ms > period_ms:
        msg = (
            f"{source}: field 'camera_defects.exposure_ms': {defects.exposure_ms:g} ms is "
            f"longer than the frame period ({period_ms:g} ms at {frame_rate:g} Hz); lower "
            "it or the frame rate"
        )
        raise ConfigError(msg)


def check_readout(defects: CameraDefects, height: int, frame_rate: float, *, source: str) -> None:
    """A rolling shutter reads every row within a frame period
    (:func:`flylog.io.shutter.readout_excess`): ConfigError naming
    ``camera_defects.row_period_us`` in ``source`` and the bound when ``height`` rows of it
    take longer."""
    excess = None if defects.ideal else readout_excess(defects.row_period_us, height, frame_rate)
    if excess is not None:
        msg = (
            f"{source}: field 'camera_defects.row_period_us': {excess}, or lower the frame "
            "rate or the resolution"
        )
        raise ConfigError(msg)
