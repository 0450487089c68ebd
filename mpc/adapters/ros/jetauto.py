"""Hiwonder JetAuto's motor messages: the controller's command as its ROS 2 driver takes it.

The driver (``ros_robot_controller``) listens on :data:`MOTOR_TOPIC` for a
``ros_robot_controller_msgs/msg/MotorsState``: a list of ``MotorState`` (``uint16 id``,
``float64 rps``), motors 1-4 = FL, RL, FR, RR in revolutions per second with the right
side negated (:data:`mpc.robots.CONVENTIONS` ``["jetauto"]``). Its odometry comes on
:data:`ODOMETRY_TOPIC` as ``nav_msgs/Odometry``, which :func:`pose_from_message` reads.

The message types are not ROS 2 Humble's own: :func:`jetauto_typestore` registers them
with rosbags (to write bags, or to serialise); :func:`motors_state` builds one from a
command. In an rclpy node build the driver's own message from :func:`jetauto_motors`'
(id, rps) pairs (docs/guide/adapters.md, "JetAuto on ROS 2").
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mpc.control.command import Command
from mpc.errors import ControllerError
from mpc.robots.description.conventions import CONVENTIONS
from trajectories.rosbag import require_rosbags

require_rosbags()
from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: E402

#: The driver's motor command topic.
MOTOR_TOPIC = "/ros_robot_controller/set_motor"
#: The robot's odometry topic (``nav_msgs/Odometry``, frame ``odom``).
ODOMETRY_TOPIC = "/odom"
#: Message type names of the driver's motor command.
MOTOR_STATE = "ros_robot_controller_msgs/msg/MotorState"
MOTORS_STATE = "ros_robot_controller_msgs/msg/MotorsState"

_JETAUTO = CONVENTIONS["jetauto"]
_MOTOR_IDS = _JETAUTO.ids or ()  # the driver's ids, in the convention's order
_DEFINITIONS = {
    MOTOR_STATE: "uint16 id\nfloat64 rps\n",
    MOTORS_STATE: "ros_robot_controller_msgs/MotorState[] data\n",
}


@functools.cache
def jetauto_typestore() -> Any:
    """A rosbags typestore of ROS 2 Humble's types plus the driver's motor messages."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    types: dict[str, Any] = {}
    for name, text in _DEFINITIONS.items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


def jetauto_motors(command: Command | ArrayLike) -> list[tuple[int, float]]:
    """(motor id, rps) for motors 1-4, from a :class:`~mpc.control.command.Command` or one
    tick's Mecanum wheel speeds in our order (FL, FR, RL, RR) [rad/s]."""
    speeds = command.wheel_speeds if isinstance(command, Command) else command
    shape = np.shape(speeds)
    if shape != (4,):
        raise ControllerError(f"JetAuto motors: one tick's 4 wheel speeds [rad/s] expected, "
                              f"got shape {shape}")
    rps = _JETAUTO.from_ours(speeds)
    return [(motor, float(value)) for motor, value in zip(_MOTOR_IDS, rps, strict=True)]


def motors_state(command: Command | ArrayLike) -> Any:
    """The driver's ``MotorsState`` message (a rosbags dataclass) for ``command``."""
    store = jetauto_typestore()
    motor = store.types[MOTOR_STATE]
    return store.types[MOTORS_STATE](
        data=[motor(id=ident, rps=rps) for ident, rps in jetauto_motors(command)])
