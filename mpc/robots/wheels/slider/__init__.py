"""Steered wheels on radial sliders (SWOM), whose steer angles and slider positions are
joint states: the robot (:mod:`.robot`), its kinematics (:mod:`.kinematics`), its joint rows
and steer schedule (:mod:`.rows`) and its limits for the solvers (:mod:`.limits`)."""

from mpc.robots.wheels.slider.kinematics import SliderUnit, slider_twist
from mpc.robots.wheels.slider.robot import SliderRobot, slider

__all__ = ["SliderRobot", "SliderUnit", "slider", "slider_twist"]
