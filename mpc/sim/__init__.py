"""The simulation harness (not the controller): a plant, a closed loop, baselines, metrics.

- :mod:`.plant`: the simulated robot (RK4 of the wheels' actual motion, with
  motor lag, delay, noise, slip and steering rate);
- :mod:`.motor_plant`: the robot driven through its DC motors (voltage, current,
  back-EMF, battery sag, traction and slip), ``plant="motor"``;
- :mod:`.motor_substep`: its physics, one implicit-Euler sub-step of body, wheels and contacts;
- :mod:`.simulate`: the closed loop, :func:`simulate`;
- :mod:`.recorder`: :class:`Recorder`, the same record from a loop of your own (plot and
  report it with :mod:`mpc.plot`);
- :mod:`.result`: :class:`SimResult` and its metrics;
- :mod:`.baselines`: feedforward + P controllers with per-wheel clipping or desaturation;
- :mod:`.setpoint`: feedforward + P through a swerve setpoint generator (Team 254 style,
  :mod:`.setpoint_generator`);
- :mod:`.slider_plant`, :mod:`.slider_baseline`, :mod:`.slider_run`: slider robots' own
  plant (joint states integrated, the stroke a hard stop), reactive baseline and closed
  loop (``simulate`` and ``FeedforwardPController`` take them for slider robots);
- :mod:`.bag`: :func:`write_bag`, a run as a ROS 2 bag (MCAP) for Foxglove or RViz (the
  ``ros`` extra, imported only when called).
"""

from mpc.errors import SimulationError as _Error
from mpc.sim.bag import write_bag
from mpc.sim.baselines import SATURATIONS, FeedforwardPController
from mpc.sim.motor_plant import MotorPlant, MotorPlantConfig
from mpc.sim.plant import PLANT_PRESETS, Plant, PlantConfig
from mpc.sim.recorder import Recorder
from mpc.sim.result import LIMIT_RTOL, SimResult
from mpc.sim.setpoint import FeedforwardPSetpointController, SwerveSetpoint, generate_setpoint
from mpc.sim.simulate import TrackingController, simulate
from mpc.sim.slider_baseline import ReactiveSliderController
from mpc.sim.slider_plant import SliderPlant, SliderSimPlant
from mpc.sim.slider_run import SliderRun, run_slider
from mpc.validation import checked_public as _checked_public

__all__ = [
    "LIMIT_RTOL",
    "PLANT_PRESETS",
    "SATURATIONS",
    "FeedforwardPController",
    "FeedforwardPSetpointController",
    "MotorPlant",
    "MotorPlantConfig",
    "Plant",
    "PlantConfig",
    "ReactiveSliderController",
    "Recorder",
    "SimResult",
    "SliderPlant",
    "SliderRun",
    "SliderSimPlant",
    "SwerveSetpoint",
    "TrackingController",
    "generate_setpoint",
    "run_slider",
    "simulate",
    "write_bag",
]

# Arguments that do not fit a public callable's signature raise SimulationError, not TypeError.
_checked_public(globals(), _Error)
